// SPDX-License-Identifier: BSD-3-Clause
// `adit map ...`: inspect, convert, query and draw maps. Thin: parse, call the map library, print.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/world.hpp"
#include "adit/map/map_summary.hpp"
#include "adit/map/readers/import.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"
#include "common/cli.hpp"
#include "common/json_output.hpp"
#include "common/graph_output.hpp"
#include "common/plan_output.hpp"
#include "common/points_csv.hpp"
#include "common/progress.hpp"
#include "common/render_topview.hpp"
#include "convert_verb.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using namespace adit;
using namespace adit::map;

struct MapArgs {
  std::string path;
  std::string unknown = "rock";
  bool quiet = false;
  std::string max_memory;  // empty: the machine's budget (budgetOf), 4G for an import (runImportConvert)
  std::string crop;
  bool no_cache = false;  // query and graph: --no-cache
};

void addMapArgs(CLI::App* cmd, MapArgs* a) {
  cmd->add_option("MAP", a->path, "Map file: survey network .yaml, OctoMap .bt or .ot")->required();
  cmd->add_option("--unknown", a->unknown, "Unknown space counts as: rock (default, surveyed mines) or free")
      ->check(CLI::IsMember({"rock", "free"}));
  cmd->add_flag("-q,--quiet", a->quiet, "No progress output");
  cmd->add_option("--max-memory", a->max_memory,
                  maxMemoryHelp("loading, the distance field and the roadway graph (a scan or mesh import's "
                                "working grid: 4G unless given)"));
  cmd->add_option("--crop", a->crop,
                  "Only the part of the map inside xmin,ymin,zmin,xmax,ymax,zmax (metres); a survey is cut "
                  "before it is voxelized");
}

// --max-memory as a budget (also used by the verbs for what they build after loading).
StatusOr<MemoryBudget> budgetOf(const MapArgs& a) {
  ADIT_ASSIGN_OR_RETURN(const std::uint64_t bytes, memoryBudgetOf(a.max_memory));
  return MemoryBudget{bytes};
}

// Loads a map (for a survey, with its network) and ends the progress line.
StatusOr<LoadedMap> load(const MapArgs& a, ProgressBar& bar) {
  StatusOr<UnknownPolicy> policy = parseUnknownPolicy(a.unknown);
  if (!policy.ok()) return policy.status();
  LoadOptions options;
  options.unknown_policy = *policy;
  options.progress = bar.callback();
  ADIT_ASSIGN_OR_RETURN(const MemoryBudget budget, budgetOf(a));
  options.max_memory_bytes = budget.max_bytes;
  if (!a.crop.empty()) {
    StatusOr<Aabb> box = parseBox(a.crop);
    if (!box.ok()) return invalidArgument("--crop: " + box.status().message());
    options.crop = *box;
  }
  StatusOr<LoadedMap> loaded = loadMapAndSurvey(a.path, options);
  bar.finish();
  return loaded;
}

void addCacheFlag(CLI::App* cmd, MapArgs* a) {
  cmd->add_flag("--no-cache", a->no_cache,
                "Build the map's octree and distance field afresh: neither read nor write the map cache");
}

WorldOptions cacheWorldOptions(const MapArgs& a, ProgressBar& bar) {
  WorldOptions wo;
  wo.load.progress = bar.callback();
  if (StatusOr<UnknownPolicy> p = parseUnknownPolicy(a.unknown); p.ok()) wo.load.unknown_policy = *p;
  if (StatusOr<MemoryBudget> b = budgetOf(a); b.ok()) wo.load.max_memory_bytes = b->max_bytes;
  wo.cache = verbCacheOptions(a.no_cache);
  // A cropped map is another world than the file's: never cached.
  wo.cache.enabled = wo.cache.enabled && a.crop.empty();
  return wo;
}

// The world from the map cache, if it is asked for and holds a valid one; NotFound otherwise,
// with what was refused in `report` (for storeWorld after the build).
StatusOr<World> cachedWorld(const MapArgs& a, ProgressBar& bar, MapCacheReport* report) {
  const WorldOptions wo = cacheWorldOptions(a, bar);
  if (!wo.cache.enabled) return notFound("no cache");
  StatusOr<World> w = findCachedWorld(a.path, wo, report);
  bar.finish();
  if (w.ok() && !a.quiet) logCacheReport(*w);
  return w;
}

void storeWorld(const MapArgs& a, ProgressBar& bar, World& world, MapCacheReport report) {
  const WorldOptions wo = cacheWorldOptions(a, bar);
  if (!wo.cache.enabled) return;
  storeCachedWorld(world, wo, std::move(report));
  if (!a.quiet) logCacheReport(world);
}

std::string fmtCount(std::uint64_t n) {
  std::string s = std::to_string(n);
  for (int i = int(s.size()) - 3; i > 0; i -= 3) s.insert(std::size_t(i), ",");
  return s;
}

// A scan or a mesh is not a voxel map yet: what the file itself holds (its points or triangles,
// their bounds, a recorded viewpoint) and how to make it one.
int runGeometryInfo(const MapArgs& a, bool json) {
  StatusOr<Geometry> g = readGeometry(a.path);
  if (!g.ok()) return report(g.status());
  Aabb box;
  for (const Vec3& p : g->points) box.extend(p);
  const char* kind = g->isMesh() ? "mesh" : "point_cloud";
  const std::string next = "adit map convert " + a.path + " OUT.bt --seed X,Y,Z (a point inside a roadway)" +
                           (g->isMesh() ? "" : " or --trajectory POSES.csv");
  if (json) {
    nlohmann::ordered_json j;
    j["file"] = a.path;
    j["format"] = kind;
    j[g->isMesh() ? "vertices" : "points"] = g->points.size();
    j["triangles"] = g->triangles.size();
    if (g->points.empty()) j["bounds"] = nullptr;
    else j["bounds"] = {{"min", mmPoint(box.min)}, {"max", mmPoint(box.max)}};
    j["viewpoint"] = g->viewpoint ? mmPoint(*g->viewpoint) : nlohmann::ordered_json();
    j["to_voxel_map"] = next;
    std::cout << stamped("adit.map.geometry_info", std::move(j)).dump(2) << "\n";
    return kExitOk;
  }
  std::printf("file         %s\n", a.path.c_str());
  if (g->isMesh())
    std::printf("mesh         %s vertices, %s triangles\n", fmtCount(g->points.size()).c_str(),
                fmtCount(g->triangles.size()).c_str());
  else
    std::printf("point cloud  %s points\n", fmtCount(g->points.size()).c_str());
  if (!g->points.empty()) {
    const Vec3 size = box.size();
    std::printf("bounds       x [%.2f, %.2f]  y [%.2f, %.2f]  z [%.2f, %.2f] m\n", box.min.x(), box.max.x(), box.min.y(),
                box.max.y(), box.min.z(), box.max.z());
    std::printf("size         %.1f x %.1f x %.1f m\n", size.x(), size.y(), size.z());
  }
  if (g->viewpoint)
    std::printf("viewpoint    %.2f, %.2f, %.2f\n", g->viewpoint->x(), g->viewpoint->y(), g->viewpoint->z());
  std::printf("voxel map    none yet: %s\n", next.c_str());
  return kExitOk;
}

int runInfo(const MapArgs& a, bool json) {
  if (isImportFormat(a.path)) return runGeometryInfo(a, json);
  ProgressBar bar(a.quiet);
  StatusOr<LoadedMap> loaded = load(a, bar);
  if (!loaded.ok()) return report(loaded.status());
  const OccupancyMap& map = loaded->map;
  const MapStats& s = map.stats();
  // The estimate is a convenience: a map too sparse (or too large for --max-memory) for it still
  // gets its summary.
  const double max_cells = double(budgetOf(a)->max_bytes) / 5.0;  // 5 bytes per top-view cell
  StatusOr<RoadwayLengthEstimate> est_or = estimateRoadwayLength(map, max_cells);
  std::optional<RoadwayLengthEstimate> est;
  if (est_or.ok()) est = *est_or;
  else std::fprintf(stderr, "adit: warning: no roadway length estimate: %s\n", est_or.status().message().c_str());
  const double v3 = s.voxelVolume();
  const bool survey = loaded->survey.has_value();
  const bool has_length = survey || est.has_value();
  const double length = survey ? loaded->survey->totalLength() : est ? est->length_m : 0.0;
  if (json) {
    nlohmann::ordered_json j;
    j["file"] = a.path;
    j["format"] = survey ? "survey" : "octomap";
    j["resolution_m"] = s.resolution_m;
    j["max_extent_m"] = maxMapExtent(s.resolution_m);
    j["unknown_policy"] = unknownPolicyName(map.unknownPolicy());
    j["bounds"] = {{"min", mmPoint(s.bounds.min)}, {"max", mmPoint(s.bounds.max)}};
    j["voxels"] = {{"free", s.free_voxels}, {"occupied", s.occupied_voxels}, {"unknown", s.unknown_voxels}};
    // Cubic metres to the litre: a 5 cm voxel is 0.125 l, so whole voxels stay visible.
    j["volume_m3"] = {{"free", roundTo(double(s.free_voxels) * v3, 6)},
                      {"occupied", roundTo(double(s.occupied_voxels) * v3, 6)},
                      {"unknown", roundTo(double(s.unknown_voxels) * v3, 6)}};
    j["octree_nodes"] = s.octree_nodes;
    j["roadway_length_m"] = has_length ? nlohmann::ordered_json(mm(length)) : nlohmann::ordered_json();
    j["roadway_length_method"] = survey ? "survey centrelines" : "footprint estimate";
    j["roadway_length_estimate_m"] = est ? nlohmann::ordered_json(mm(est->length_m)) : nlohmann::ordered_json();
    j["median_width_m"] = est ? nlohmann::ordered_json(mm(est->median_width_m)) : nlohmann::ordered_json();
    if (survey) {
      const SurveyNetwork& n = *loaded->survey;
      j["survey"] = {{"name", n.name}, {"stations", n.stations.size()}, {"sections", n.sections.size()},
                     {"roadways", n.roadways.size()}, {"rock_shell_m", mm(n.rock_shell_m)}};
    }
    std::cout << stamped("adit.map.info", std::move(j)).dump(2) << "\n";
    return kExitOk;
  }
  const Vec3 size = s.bounds.size();
  std::printf("map          %s\n", a.path.c_str());
  if (survey) {
    const SurveyNetwork& n = *loaded->survey;
    std::printf("survey       %s%s%zu stations, %zu sections, %zu roadways\n", n.name.c_str(),
                n.name.empty() ? "" : ": ", n.stations.size(), n.sections.size(), n.roadways.size());
  }
  std::printf("resolution   %.3f m  (OctoMap keys: coordinates within +-%.1f m of the origin)\n", s.resolution_m,
              maxMapExtent(s.resolution_m));
  std::printf("bounds       x [%.2f, %.2f]  y [%.2f, %.2f]  z [%.2f, %.2f] m\n", s.bounds.min.x(), s.bounds.max.x(),
              s.bounds.min.y(), s.bounds.max.y(), s.bounds.min.z(), s.bounds.max.z());
  std::printf("size         %.1f x %.1f x %.1f m\n", size.x(), size.y(), size.z());
  std::printf("free         %15s voxels  %12.1f m3\n", fmtCount(s.free_voxels).c_str(), double(s.free_voxels) * v3);
  std::printf("occupied     %15s voxels  %12.1f m3\n", fmtCount(s.occupied_voxels).c_str(), double(s.occupied_voxels) * v3);
  std::printf("unknown      %15s voxels  %12.1f m3  (counted as %s)\n", fmtCount(s.unknown_voxels).c_str(),
              double(s.unknown_voxels) * v3, unknownPolicyName(map.unknownPolicy()));
  if (survey && est)
    std::printf("roadways     %.1f m of centreline (footprint estimate %.1f m, median width %.2f m)\n", length,
                est->length_m, est->median_width_m);
  else if (survey)
    std::printf("roadways     %.1f m of centreline\n", length);
  else if (est)
    std::printf("roadways     ~%.1f m (estimate from the free-space footprint, median width %.2f m)\n", length,
                est->median_width_m);
  else
    std::printf("roadways     unknown (no estimate for this map)\n");
  std::printf("octree       %s nodes\n", fmtCount(s.octree_nodes).c_str());
  return kExitOk;
}

int runConvertOnly(const MapArgs& a, const std::string& out, ConvertArgs c) {
  c.in = a.path;
  c.out = out;
  c.unknown = a.unknown;
  c.quiet = a.quiet;
  c.max_memory = a.max_memory;
  if (needsImport(c)) return runImportConvert(c);
  StatusOr<MapFormat> target = formatFromPath(out);
  if (!target.ok()) return report(target.status());
  if (*target == MapFormat::kSurveyYaml)
    return report(invalidArgument(out + ": can only convert to an OctoMap .bt or .ot file"));
  ProgressBar bar(a.quiet);
  StatusOr<LoadedMap> loaded = load(a, bar);
  if (!loaded.ok()) return report(loaded.status());
  if (!a.quiet) std::fprintf(stderr, "writing %s ...\n", out.c_str());
  Status w = writeOctomap(loaded->map, out);
  if (!w.ok()) return report(w);
  if (!a.quiet)
    std::fprintf(stderr, "wrote %s: %s octree nodes, resolution %.3f m\n", out.c_str(),
                 fmtCount(loaded->map.stats().octree_nodes).c_str(), loaded->map.resolution());
  return kExitOk;
}

// `--cache`: OUT loaded through the map cache, which writes it (asked for by name, so
// ADIT_NO_MAP_CACHE does not apply). Not writable anywhere: exit 1.
int runConvert(const MapArgs& a, const std::string& out, const ConvertArgs& c) {
  const int rc = runConvertOnly(a, out, c);
  if (rc != kExitOk || !c.cache) return rc;
  ProgressBar bar(a.quiet);
  WorldOptions wo;
  wo.load.progress = bar.callback();
  if (StatusOr<UnknownPolicy> p = parseUnknownPolicy(a.unknown); p.ok()) wo.load.unknown_policy = *p;
  wo.cache.enabled = true;
  StatusOr<World> world = World::load(out, wo);
  bar.finish();
  if (!world.ok()) return report(world.status());
  if (!a.quiet) logCacheReport(*world);
  const MapCacheReport& r = world->cacheReport();
  if (r.used.empty() && r.written.empty())
    return report(internalError(out + ": --cache: the map cache could not be written: " + r.write_error));
  return kExitOk;
}

int runQuery(const MapArgs& a, const std::string& points_file, const std::vector<std::string>& points,
             const std::string& out_path) {
  std::vector<Vec3> pts;
  for (std::size_t i = 0; i < points.size(); ++i) {
    StatusOr<Vec3> p = parsePoint(points[i], "point " + std::to_string(i + 1));
    if (!p.ok()) return report(p.status());
    pts.push_back(*p);
  }
  if (!points_file.empty()) {
    StatusOr<MemoryBudget> budget = budgetOf(a);
    if (!budget.ok()) return report(budget.status());
    StatusOr<std::vector<Vec3>> more = readPointsCsv(points_file, budget->max_bytes);
    if (!more.ok()) return report(more.status());
    pts.insert(pts.end(), more->begin(), more->end());
  }
  if (pts.empty()) return report(invalidArgument("no points given: use --points FILE.csv or x,y,z arguments"));
  ProgressBar bar(a.quiet);
  MapCacheReport cache_report;
  StatusOr<World> world = cachedWorld(a, bar, &cache_report);
  if (!world.ok()) {
  StatusOr<LoadedMap> loaded = load(a, bar);
  if (!loaded.ok()) return report(loaded.status());
  // Counted without allocating a tile: `--unknown free` on a large box used to take minutes and
  // tens of GB before failing.
  const MemoryBudget budget = *budgetOf(a);
  const DistanceFieldEstimate need = estimateDistanceField(loaded->map);
  Status fits = budget.check(need.bytes, "the distance field (" + std::to_string(need.tiles) + " tiles of 16^3 voxels)",
                             "use --crop xmin,ymin,zmin,xmax,ymax,zmax around the points" +
                                 std::string(loaded->map.unknownPolicy() == UnknownPolicy::kFree ? ", --unknown rock" : "") +
                                 " or raise --max-memory");
  if (!fits.ok()) return report(fits);
  const auto max_tiles = std::uint64_t(double(budget.max_bytes) / distanceFieldBytesPerTile()) + 1;
  WorldOptions wo;
  wo.load.progress = bar.callback();
  wo.max_field_blocks = max_tiles;
  world = World::build(std::move(loaded).value(), a.path, wo);
  bar.finish();
  if (!world.ok()) return report(world.status());
  storeWorld(a, bar, *world, std::move(cache_report));
  }
  const DistanceField* df = &world->field();
  // All input is validated before the first byte of output; rows are streamed (no copy of the
  // whole table in memory). Coordinates echo the input exactly so rows join back to it.
  auto writeRows = [&](std::ostream& os) {
    os << "x,y,z,state,distance,gx,gy,gz\n";
    char buf[160];
    for (const Vec3& p : pts) {
      const DistanceSample s = df->query(p);
      std::snprintf(buf, sizeof buf, ",%s,%.4f,%.6f,%.6f,%.6f\n", voxelStateName(world->map().state(p)), s.distance,
                    s.gradient.x(), s.gradient.y(), s.gradient.z());
      os << roundTripNumber(p.x()) << ',' << roundTripNumber(p.y()) << ',' << roundTripNumber(p.z()) << buf;
    }
    return bool(os);
  };
  if (out_path.empty()) return writeRows(std::cout) ? kExitOk : kExitFailure;
  Status w = writeFileAtomically(out_path, writeRows);
  return w.ok() ? kExitOk : report(w);
}

int runSlice(const MapArgs& a, const std::optional<double>& z, double band, double ppm, const std::string& out,
             const std::string& title) {
  TopViewOptions o;
  o.slice_z_m = z;
  o.slice_band_m = band;
  o.pixels_per_m = ppm;
  if ((z && !std::isfinite(*z)) || !std::isfinite(band) || band < 0 || !std::isfinite(ppm) || ppm < 0)
    return report(invalidArgument("--z, --band and --px-per-m must be finite (band and scale >= 0)"));
  ProgressBar bar(a.quiet);
  StatusOr<LoadedMap> loaded = load(a, bar);
  if (!loaded.ok()) return report(loaded.status());
  o.title = !title.empty() ? title
            : loaded->survey && !loaded->survey->name.empty() ? loaded->survey->name
                                                               : std::filesystem::path(a.path).filename().string();
  Status s = renderTopView(loaded->map, o, out);
  if (!s.ok()) return report(s);
  if (!a.quiet) std::fprintf(stderr, "wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace

struct GraphArgs {
  std::string robot = "sphere:0.4", mode = "fly", out, picture;
  double margin = 0.2, slice = 1.0;
  bool json = false;
};

// The roadway network the planner routes on, as adit sees it for this robot.
int runGraph(const MapArgs& a, const GraphArgs& g) {
  if (isImportFormat(a.path))
    return report(invalidArgument(a.path + " is a scan or a mesh, not a voxel map yet: adit map convert " + a.path +
                                  " OUT.bt --seed X,Y,Z first"));
  global::GlobalPlannerParams params;
  StatusOr<RobotShape> robot = parseRobot(g.robot);
  if (!robot.ok()) return report(invalidArgument("--robot: " + robot.status().message()));
  params.robot = *robot;
  StatusOr<global::PlanMode> mode = global::parsePlanMode(g.mode);
  if (!mode.ok()) return report(invalidArgument("--mode: " + mode.status().message()));
  params.mode = *mode;
  if (!(std::isfinite(g.margin) && g.margin >= 0)) return report(invalidArgument("--margin must be >= 0 m"));
  if (!(std::isfinite(g.slice) && g.slice > 0))
    return report(invalidArgument("--slice must be > 0 m (the thickness of the graph's slices), got " + std::to_string(g.slice)));
  params.safety_margin_m = g.margin;
  params.skeleton_cell_m = g.slice;
  if (Status s = params.validate(); !s.ok()) return report(s);
  for (const std::string* f : {&g.out, &g.picture}) {
    if (f->empty()) continue;
    std::string ext = std::filesystem::path(*f).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    const bool ok = f == &g.out ? (ext == ".json" || ext == ".geojson" || ext == ".dxf") : (ext == ".png" || ext == ".svg");
    if (!ok)
      return report(invalidArgument((f == &g.out ? "--out " : "--picture ") + *f +
                                    (f == &g.out ? ": expected a .json, .geojson or .dxf file" : ": expected a .png or .svg file")));
  }
  StatusOr<MemoryBudget> budget = budgetOf(a);
  if (!budget.ok()) return report(budget.status());
  params.max_graph_memory_bytes = budget->max_bytes;
  ProgressBar bar(a.quiet);
  MapCacheReport cache_report;
  StatusOr<World> world = cachedWorld(a, bar, &cache_report);
  if (!world.ok()) {
    StatusOr<LoadedMap> loaded = load(a, bar);
    if (!loaded.ok()) return report(loaded.status());
    WorldOptions wo;
    wo.load.progress = bar.callback();
    world = World::build(std::move(loaded).value(), a.path, wo);
    bar.finish();
    if (!world.ok()) return report(world.status());
    storeWorld(a, bar, *world, std::move(cache_report));
  }
  const DistanceField* field = &world->field();
  const SurveyNetwork* survey = world->survey();
  StatusOr<global::GlobalPlanner> planner = global::GlobalPlanner::create(world->map(), *field, params, survey);
  if (!planner.ok()) return report(planner.status());
  const global::RoadwayGraph& graph = planner->graph();
  GraphContext c;
  c.map_path = a.path;
  c.source = survey ? "survey" : "free_space";
  c.robot = g.robot;
  c.margin_m = g.margin;
  c.required_clearance_m = planner->requiredClearance();
  if (!g.out.empty()) {
    if (Status s = writeGraph(graph, *field, c, g.out); !s.ok()) return report(s);
  }
  if (!g.picture.empty()) {
    const std::string title = "Roadway graph of " + std::filesystem::path(a.path).filename().string() + " (" +
                              (survey ? "survey" : "free space, " + g.robot) + ")";
    if (Status s = drawGraph(world->map(), graph, title, g.picture); !s.ok()) return report(s);
  }
  if (g.json) {
    std::cout << graphJson(graph, *field, c).dump(2) << "\n";
    return finishStdout(kExitOk);
  }
  int junctions = 0, ends = 0;
  for (std::size_t n = 0; n < graph.nodes().size(); ++n) {
    const std::string kind = nodeKind(graph, int(n));
    junctions += kind == "junction";
    ends += kind == "end";
  }
  std::printf("map          %s\n", a.path.c_str());
  std::printf("graph        %s, for %s with %.2f m margin (clearance >= %.2f m)\n",
              survey ? "the survey's roadways" : "the robot's free space", g.robot.c_str(), g.margin,
              planner->requiredClearance());
  std::printf("network      %zu edges, %.1f m; %d junctions, %d ends\n", graph.edges().size(), graph.totalLength(),
              junctions, ends);
  if (graph.fromFreeSpaceMap()) {
    const global::FreeSpaceGraphInfo& i = graph.freeSpaceInfo();
    std::printf("built        %s voxels in %llu connected part%s, %llu slice pieces, %llu short branches folded; "
                "%.2f s, %.1f MiB\n",
                fmtCount(i.voxels).c_str(), static_cast<unsigned long long>(i.regions), i.regions == 1 ? "" : "s",
                static_cast<unsigned long long>(i.pieces), static_cast<unsigned long long>(i.folded_branches),
                i.seconds, double(i.memory_bytes) / (1 << 20));
  }
  return finishStdout(kExitOk);
}

void registerMapVerbs(CLI::App& app, int* rc) {
  CLI::App* map = app.add_subcommand("map", "Inspect, convert, query and draw mine maps");
  map->require_subcommand(1);

  {
    auto a = std::make_shared<MapArgs>();
    auto json = std::make_shared<bool>(false);
    CLI::App* cmd = map->add_subcommand("info", "Resolution, bounds, free/occupied/unknown volumes, roadway length "
                                                "(of a scan or mesh: its points, bounds and how to convert it)");
    addMapArgs(cmd, a.get());
    cmd->add_flag("--json", *json, "Machine-readable JSON on stdout");
    cmd->callback([=] { *rc = runInfo(*a, *json); });
  }
  {
    auto a = std::make_shared<MapArgs>();
    auto out = std::make_shared<std::string>();
    auto c = std::make_shared<ConvertArgs>();
    CLI::App* cmd = map->add_subcommand(
        "convert", "Convert a survey .yaml, a point cloud (.pcd .ply .xyz .csv .las) or a mesh (.stl .obj .ply .dae) "
                   "to an OctoMap .bt/.ot file");
    addMapArgs(cmd, a.get());
    cmd->get_option("MAP")->description("Input: survey .yaml, OctoMap .bt/.ot, point cloud (.pcd .ply .xyz .csv .las), "
                                        "mesh (.stl .obj .ply .dae), DXF centrelines or a ROS map_server .yaml");
    cmd->add_option("OUT", *out, "Output .bt or .ot (written atomically: never a half file)")->required();
    addConvertOptions(cmd, c.get());
    cmd->callback([=] { *rc = runConvert(*a, *out, *c); });
  }
  {
    auto a = std::make_shared<MapArgs>();
    auto file = std::make_shared<std::string>();
    auto pts = std::make_shared<std::vector<std::string>>();
    auto out = std::make_shared<std::string>();
    CLI::App* cmd = map->add_subcommand(
        "query", "State, distance to rock and its gradient at points; CSV x,y,z,state,distance,gx,gy,gz");
    addMapArgs(cmd, a.get());
    addCacheFlag(cmd, a.get());
    cmd->add_option("POINTS", *pts, "Points as x,y,z (metres)");
    cmd->add_option("--points", *file, "CSV file with one x,y,z per line (header and # comments allowed)");
    cmd->add_option("-o,--out", *out, "Write the CSV here instead of stdout");
    cmd->callback([=] { *rc = runQuery(*a, *file, *pts, *out); });
  }
  {
    auto a = std::make_shared<MapArgs>();
    auto z = std::make_shared<double>(std::numeric_limits<double>::quiet_NaN());
    auto band = std::make_shared<double>(0.0);
    auto ppm = std::make_shared<double>(0.0);
    auto out = std::make_shared<std::string>();
    auto title = std::make_shared<std::string>();
    CLI::App* cmd = map->add_subcommand(
        "slice", "Top-view picture (PNG/SVG) with scale bar and north arrow: a slice at --z, or a projection");
    addMapArgs(cmd, a.get());
    CLI::Option* zopt = cmd->add_option("--z", *z, "Slice height [m]; without it, a top view of all heights "
                                                   "coloured by floor elevation");
    cmd->add_option("--band", *band, "With --z: free if any voxel within +-band/2 of z is free [m]");
    cmd->add_option("--px-per-m", *ppm, "Pixels per metre (default: fit about 2000 px)");
    cmd->add_option("--title", *title, "Title drawn on the picture (default: map name)");
    cmd->add_option("-o,--out", *out, "Output .png or .svg")->required();
    cmd->callback([=] {
      std::optional<double> zz;
      if (zopt->count() > 0) zz = *z;
      *rc = runSlice(*a, zz, *band, *ppm, *out, *title);
    });
  }
  {
    auto a = std::make_shared<MapArgs>();
    auto g = std::make_shared<GraphArgs>();
    CLI::App* cmd = map->add_subcommand(
        "graph", "The roadway network adit routes on (the survey's, or built from the robot's free space): "
                 "summary, JSON/GeoJSON/DXF and a picture");
    addMapArgs(cmd, a.get());
    addCacheFlag(cmd, a.get());
    cmd->add_option("--robot", g->robot, "sphere:r | capsule:r,len | box:x,y,z | cylinder:r,h  [m]")->capture_default_str();
    cmd->add_option("--margin", g->margin, "Safety margin kept from rock beyond the robot [m]")->capture_default_str();
    cmd->add_option("--mode", g->mode, "fly or ground")->capture_default_str();
    cmd->add_option("--slice", g->slice, "Free-space graph: thickness of its geodesic slices [m]")->capture_default_str();
    cmd->add_option("-o,--out", g->out, "Write the graph: .json, .geojson (LineStrings, map metres) or .dxf (3-D polylines)");
    cmd->add_option("--picture", g->picture, "Top view of the graph over the map (.png or .svg)");
    cmd->add_flag("--json", g->json, "The graph as JSON on stdout instead of the summary");
    cmd->callback([=] { *rc = runGraph(*a, *g); });
  }
}

}  // namespace adit::tools
