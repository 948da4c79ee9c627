// SPDX-License-Identifier: BSD-3-Clause
// `adit map convert` for scans and meshes: read, fix the frame (Y-up, origin), recover free
// space, write the octree atomically; a summary on stderr (or JSON on stdout with --json).
#include "convert_verb.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "adit/map/free_space.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/readers/dxf.hpp"
#include "adit/map/readers/import.hpp"
#include "adit/map/readers/ros_map.hpp"
#include "adit/map/size_estimate.hpp"
#include "adit/map/survey_network.hpp"
#include "common/cli.hpp"
#include "common/json_output.hpp"
#include "common/points_csv.hpp"
#include "common/progress.hpp"

namespace adit::tools {

using namespace adit::map;

namespace {

std::string xyz(const Vec3& v) {
  char b[128];
  std::snprintf(b, sizeof b, "%.17g,%.17g,%.17g", v.x(), v.y(), v.z());
  return b;
}

// As --seed takes it, to the millimetre.
std::string seedText(const Vec3& v) {
  char b[128];
  std::snprintf(b, sizeof b, "%.3f,%.3f,%.3f", v.x(), v.y(), v.z());
  return b;
}

// The .bt format has no room for metadata, so a shifted map gets a sidecar beside it.
Status writeOriginSidecar(const std::string& out, const Vec3& origin, bool automatic) {
  nlohmann::ordered_json j;
  j["map"] = out;
  j["origin"] = {origin.x(), origin.y(), origin.z()};
  j["origin_source"] = automatic ? "automatic" : "--origin";
  j["meaning"] = "map coordinates = input coordinates - origin";
  return writeFileAtomically(out + ".origin.json",
                             [&](std::ostream& f) { return bool(f << stamped("adit.map.origin", j).dump(2) << "\n"); });
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// A survey network (from YAML or DXF centrelines), shifted and voxelized.
int convertSurvey(const ConvertArgs& a, StatusOr<SurveyNetwork> net, const Vec3& origin, bool automatic,
                  UnknownPolicy policy, ProgressBar& bar) {
  if (!net.ok()) return report(net.status());
  for (auto& [name, p] : net->stations) p = toMapFrame(p, a.up == "y", origin);
  if (a.resolution) net->resolution_m = *a.resolution;
  VoxelizeOptions vo;
  vo.unknown_policy = policy;
  vo.progress = bar.callback();
  StatusOr<OccupancyMap> map = voxelize(*net, vo);
  bar.finish();
  if (!map.ok()) return report(map.status());
  Status w = writeOctomap(*map, a.out);
  if (!w.ok()) return report(w);
  if (!origin.isZero()) {
    Status s = writeOriginSidecar(a.out, origin, automatic);
    if (!s.ok()) return report(s);
  }
  if (!a.quiet)
    std::fprintf(stderr, "wrote %s: %zu roadways, %.1f m of centreline, shifted by -(%s)\n", a.out.c_str(),
                 net->roadways.size(), net->totalLength(), xyz(origin).c_str());
  return kExitOk;
}

int convertDxfCentrelines(const ConvertArgs& a, const DxfContents& d, const std::optional<Vec3>& requested_origin,
                          UnknownPolicy policy, ProgressBar& bar) {
  DxfSections sections;
  if (!a.sections.empty()) {
    StatusOr<std::string> text = readFile(a.sections, std::size_t{1} << 20);
    if (!text.ok()) return report(text.status());
    StatusOr<DxfSections> s = parseDxfSections(*text, a.sections);
    if (!s.ok()) return report(s.status());
    sections = *s;
  }
  std::optional<CrossSection> fallback;
  if (!a.section.empty()) {
    StatusOr<CrossSection> s = parseSectionSpec(a.section);
    if (!s.ok()) return report(s.status());
    fallback = *s;
  }
  StatusOr<SurveyNetwork> net = dxfToSurvey(d, sections, fallback, a.resolution.value_or(0.2));
  if (!net.ok()) return report(Status(net.status().code(), a.in + ": " + net.status().message()));
  Aabb box;
  for (const auto& [name, p] : net->stations) box.extend(toMapFrame(p, a.up == "y", Vec3::Zero()));
  bool automatic = false;
  const Vec3 origin = chooseOrigin(box.inflated(net->rock_shell_m + 10.0), net->resolution_m, requested_origin, &automatic);
  return convertSurvey(a, std::move(net), origin, automatic, policy, bar);
}

bool isRosMapFile(const std::string& path) {
  StatusOr<MapFormat> f = formatFromPath(path);
  if (!f.ok() || *f != MapFormat::kSurveyYaml) return false;
  StatusOr<std::string> text = readFile(path, std::size_t{1} << 20);
  return text.ok() && isRosMapYaml(*text);
}

int convertRosMap(const ConvertArgs& a, const Vec3& origin, UnknownPolicy policy) {
  StatusOr<RosMap> ros = readRosMap(a.in);
  if (!ros.ok()) return report(ros.status());
  ExtrudeOptions o;
  o.height_m = a.height;
  o.resolution_m = a.resolution.value_or(0.0);
  o.shift = origin;
  o.unknown_policy = policy;
  StatusOr<OccupancyMap> map = extrudeRosMap(*ros, o);
  if (!map.ok()) return report(Status(map.status().code(), a.in + ": " + map.status().message()));
  Status w = writeOctomap(*map, a.out);
  if (!w.ok()) return report(w);
  if (!origin.isZero()) {
    Status s = writeOriginSidecar(a.out, origin, false);
    if (!s.ok()) return report(s);
  }
  std::uint64_t free_cells = 0, occupied_cells = 0;
  for (std::int8_t c : ros->cells) {
    free_cells += c == 0;
    occupied_cells += c == 100;
  }
  if (a.json) {
    nlohmann::ordered_json j;
    j["input"] = a.in;
    j["output"] = a.out;
    j["kind"] = "ros map";
    j["pixels"] = {{"width", ros->width}, {"height", ros->height}, {"free", free_cells}, {"occupied", occupied_cells}};
    j["resolution_m"] = map->resolution();
    j["height_m"] = a.height;
    j["voxels"] = {{"free", map->stats().free_voxels}, {"occupied", map->stats().occupied_voxels}};
    std::cout << stamped("adit.map.convert", std::move(j)).dump(2) << "\n";
    std::cout.flush();
    if (!std::cout) return report(internalError("cannot write the summary to stdout"));
  }
  if (!a.quiet)
    std::fprintf(stderr, "wrote %s: %d x %d pixels (%llu free, %llu occupied) extruded to %.2f m at %.3f m\n",
                 a.out.c_str(), ros->width, ros->height, (unsigned long long)free_cells,
                 (unsigned long long)occupied_cells, a.height, map->resolution());
  return kExitOk;
}

}  // namespace

void addConvertOptions(CLI::App* cmd, ConvertArgs* a) {
  cmd->add_option("--resolution", a->resolution, "Voxel edge [m] for imported data (default 0.2; overrides a survey's)");
  cmd->add_option("--seed", a->seed, "Flood fill the free space from this point x,y,z inside a roadway (input frame), "
                                     "or 'auto': the interior point farthest from the walls with scanned surface "
                                     "above and below (reported)");
  cmd->add_option("--trajectory", a->trajectory,
                  "Scanner poses CSV (x,y,z / x y z qx qy qz qw / t x y z qx qy qz qw / header row): free space "
                  "from rays pose -> point");
  cmd->add_option("--origin", a->origin, "Subtract x,y,z from every coordinate (e.g. UTM); default: automatic "
                                         "when the data lie far from 0, recorded in OUT.origin.json");
  cmd->add_option("--up", a->up, "Input up axis: z (default) or y ((x,y,z) -> (x,-z,y), Y-up meshes)")
      ->check(CLI::IsMember({"z", "y"}));
  cmd->add_option("--max-wall-distance", a->max_wall_distance,
                  "Flood fill stays this close to the scanned surface [m] (default 5)");
  cmd->add_option("--close", a->close, "Plug holes in the scan narrower than 2x this radius before filling [m] "
                                       "(default 0: off)");
  cmd->add_option("--hull-cell", a->hull_cell, "Hull test on lines this thick [m] (default: one voxel); "
                                               "raise it for sparse scans");
  cmd->add_option("--thin", a->thin, "Clear scanned rock no thicker than this where it borders free space "
                                     "(noise points, cables, speckle) [m] (default: one voxel; 0: off)");
  cmd->add_option("--max-ray", a->max_ray, "With --trajectory: ignore points farther than this from every pose [m]");
  cmd->add_option("--max-memory-mb", a->max_memory_mb, "Deprecated: --max-memory SIZE (kept for old scripts; warns)");
  cmd->add_option("--max-points", a->max_points, "Refuse files announcing more points (default 5e8)");
  cmd->add_option("--sections", a->sections, "DXF centrelines: YAML of cross-sections by layer (survey schema: "
                                             "sections: {LAYER: {shape: arch, width: 5, wall_height: 3}})");
  cmd->add_option("--section", a->section, "DXF centrelines: section for layers not in --sections, e.g. "
                                           "'{shape: rectangle, width: 4, height: 3}'");
  cmd->add_option("--height", a->height, "ROS map_server maps: extrude free and occupied cells from z = 0 to this [m] "
                                         "(default 2)");
  cmd->add_flag("--cache", a->cache,
                "Also build OUT's octree and distance field and write its map cache, so that the first verb to load "
                "OUT reads it instead of building them");
  cmd->add_flag("--json", a->json, "Print a JSON summary (counts, origin, timings) on stdout");
}

bool needsImport(const ConvertArgs& a) {
  return isImportFormat(a.in) || lowerExtension(a.in) == ".dxf" || isRosMapFile(a.in) || a.resolution.has_value() || !a.origin.empty() || a.up != "z" || !a.seed.empty() || !a.trajectory.empty();
}

int runImportConvert(const ConvertArgs& a) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  StatusOr<MapFormat> target = formatFromPath(a.out);
  if (!target.ok()) return report(target.status());
  if (*target == MapFormat::kSurveyYaml)
    return report(invalidArgument(a.out + ": can only convert to an OctoMap .bt or .ot file"));
  StatusOr<UnknownPolicy> policy = parseUnknownPolicy(a.unknown);
  if (!policy.ok()) return report(policy.status());
  std::optional<Vec3> requested_origin;
  if (!a.origin.empty()) {
    StatusOr<Vec3> o = parsePoint(a.origin, "--origin");
    if (!o.ok()) return report(o.status());
    requested_origin = *o;
  }
  if (!(a.max_points >= 1)) return report(invalidArgument("--max-points must be >= 1"));
  // One budget, --max-memory (default 4G here: the working grid of a scan is the import's size).
  std::uint64_t max_memory_bytes = std::uint64_t{4} << 30;
  if (a.max_memory_mb) {
    if (!a.max_memory.empty()) return report(invalidArgument("give --max-memory or the old --max-memory-mb, not both"));
    if (!(*a.max_memory_mb >= 1) || *a.max_memory_mb > 1e9) return report(invalidArgument("--max-memory-mb must be in 1..1e9"));
    std::fprintf(stderr, "adit: warning: --max-memory-mb is deprecated; use --max-memory %.0fM\n", *a.max_memory_mb);
    max_memory_bytes = std::uint64_t(*a.max_memory_mb * 1048576.0);
  } else if (!a.max_memory.empty()) {
    StatusOr<std::uint64_t> bytes = parseByteSize(a.max_memory);
    if (!bytes.ok()) return report(invalidArgument("--max-memory: " + bytes.status().message()));
    max_memory_bytes = *bytes;
  }
  ProgressBar bar(a.quiet);
  const std::string ext = lowerExtension(a.in);
  const bool is_dxf = ext == ".dxf";
  if (!isImportFormat(a.in) && !is_dxf) {
    StatusOr<MapFormat> in_format = formatFromPath(a.in);
    if (!in_format.ok()) return report(in_format.status());
    if (isRosMapFile(a.in)) return convertRosMap(a, requested_origin.value_or(Vec3::Zero()), *policy);
    if (*in_format != MapFormat::kSurveyYaml)
      return report(invalidArgument(a.in + ": --origin/--up/--seed/--trajectory apply to imported data and surveys, "
                                           "not to an existing octree"));
    return convertSurvey(a, loadSurvey(a.in), requested_origin.value_or(Vec3::Zero()), false, *policy, bar);
  }

  ImportParams p;
  p.resolution_m = a.resolution.value_or(0.2);
  p.max_wall_distance_m = a.max_wall_distance;
  p.closing_radius_m = a.close;
  p.max_ray_m = a.max_ray;
  p.hull_cell_m = a.hull_cell;
  if (a.thin && (!std::isfinite(*a.thin) || *a.thin < 0))
  {
    std::ostringstream os;
    os << *a.thin;
    return report(invalidArgument("--thin must be a finite distance >= 0 m (0: off), got " + os.str()));
  }
  p.thin_radius_m = a.thin;
  p.max_memory_bytes = max_memory_bytes;
  p.unknown_policy = *policy;
  std::optional<Vec3> seed_in;
  p.auto_seed = a.seed == "auto";
  if (!a.seed.empty() && !p.auto_seed) {
    StatusOr<Vec3> s = parsePoint(a.seed, "--seed");
    if (!s.ok()) return report(s.status());
    seed_in = *s;
  }
  std::vector<Vec3> poses;
  if (!a.trajectory.empty()) {
    StatusOr<std::vector<Vec3>> t = readTrajectory(a.trajectory);
    if (!t.ok()) return report(t.status());
    poses = *t;
  }
  // Only a PCD can bring its own viewpoint (and DXF centrelines need none); for the rest say what
  // is missing before reading.
  if (!seed_in && poses.empty() && !p.auto_seed && ext != ".pcd" && !is_dxf) {
    p.seed.reset();
    Status v = p.validate();
    if (!v.ok()) return report(v);
  }
  ReadLimits limits;
  limits.max_points = std::uint64_t(a.max_points);
  if (!a.quiet) std::fprintf(stderr, "reading %s ...\n", a.in.c_str());
  StatusOr<Geometry> g = is_dxf ? StatusOr<Geometry>(Geometry{}) : readGeometry(a.in, limits);
  if (!g.ok()) return report(g.status());
  if (is_dxf) {
    StatusOr<DxfContents> d = readDxf(a.in, limits);
    if (!d.ok()) return report(d.status());
    if (!d->polylines.empty()) return convertDxfCentrelines(a, *d, requested_origin, *policy, bar);
    if (!a.quiet) std::fprintf(stderr, "no centrelines in %s: its 3DFACEs are a mesh\n", a.in.c_str());
    g = std::move(d->faces);
  }
  const auto t_read = Clock::now();
  const bool y_up = a.up == "y";
  Aabb box;
  for (const Vec3& q : g->points) box.extend(toMapFrame(q, y_up, Vec3::Zero()));
  bool automatic = false;
  const Vec3 origin = chooseOrigin(box, p.resolution_m, requested_origin, &automatic);
  toMapFrame(&*g, y_up, origin);
  if (seed_in) p.seed = toMapFrame(*seed_in, y_up, origin);
  p.seed_name = a.seed;  // errors quote the seed as typed, in the input's frame
  for (Vec3& q : poses) q = toMapFrame(q, y_up, origin);
  p.trajectory = poses;
  if (p.trajectory.empty() && !p.seed && !p.auto_seed && g->viewpoint) p.trajectory.push_back(*g->viewpoint);
  if (automatic && !a.quiet)
    std::fprintf(stderr, "coordinates lie far from 0: shifting by origin %s (recorded in %s.origin.json)\n",
                 xyz(origin).c_str(), a.out.c_str());

  StatusOr<ImportResult> r = buildMapFromGeometry(*g, p, bar.callback());
  bar.finish();
  if (!r.ok()) {
    Status s = r.status();
    return report(Status(s.code(), a.in + ": " + s.message()));
  }
  const auto t_build = Clock::now();
  // The seed in the input's frame (what --seed takes): map frame + origin, Y-up turned back.
  std::optional<Vec3> seed_used;
  if (r->seed) {
    const Vec3 q = *r->seed + origin;
    seed_used = y_up ? Vec3(q.x(), q.z(), -q.y()) : q;
  }
  if (p.auto_seed && seed_used)
    std::fprintf(stderr, "seed auto: chose %s (input frame)\n", seedText(*seed_used).c_str());
  if (!a.quiet) std::fprintf(stderr, "writing %s ...\n", a.out.c_str());
  Status w = writeOctomap(r->map, a.out);
  if (!w.ok()) return report(w);
  if (!origin.isZero()) {
    Status s = writeOriginSidecar(a.out, origin, automatic);
    if (!s.ok()) return report(s);
  }
  const double read_s = std::chrono::duration<double>(t_read - t0).count();
  const double build_s = std::chrono::duration<double>(t_build - t_read).count();
  const double v3 = std::pow(p.resolution_m, 3);
  if (a.json) {
    nlohmann::ordered_json j;
    j["input"] = a.in;
    j["output"] = a.out;
    j["kind"] = g->isMesh() ? "mesh" : "point cloud";
    j[g->isMesh() ? "triangles" : "points"] = r->inputs;
    j["resolution_m"] = p.resolution_m;
    j["origin"] = {origin.x(), origin.y(), origin.z()};
    j["origin_source"] = requested_origin ? "--origin" : automatic ? "automatic" : "none";
    j["up"] = a.up;
    j["free_space"] = freeSpaceSourceName(r->source);
    j["seed"] = seed_used ? mmPoint(*seed_used) : nlohmann::ordered_json();
    j["seed_source"] = !seed_used ? "none" : p.auto_seed ? "auto" : "--seed";
    j["voxels"] = {{"surface", r->surface_voxels}, {"closed", r->closed_voxels}, {"free", r->free_voxels},
                  {"thin_cleared", r->thin_cleared}};
    j["free_volume_m3"] = roundTo(double(r->free_voxels) * v3, 6);
    j["working_mib"] = roundTo(double(r->working_bytes) / 1048576.0, 3);
    j["seconds"] = {{"read", us(read_s)}, {"build", us(build_s)}};
    std::cout << stamped("adit.map.convert", std::move(j)).dump(2) << "\n";
    std::cout.flush();
    if (!std::cout) return report(internalError("cannot write the summary to stdout"));
  }
  if (!a.quiet)
    std::fprintf(stderr,
                 "wrote %s: %llu %s -> %llu surface voxels, %llu plugged, %llu free (%.0f m3) by %s, "
                 "%llu thin rock voxels cleared; read %.2f s, build %.2f s\n",
                 a.out.c_str(), (unsigned long long)r->inputs, g->isMesh() ? "triangles" : "points",
                 (unsigned long long)r->surface_voxels, (unsigned long long)r->closed_voxels,
                 (unsigned long long)r->free_voxels, double(r->free_voxels) * v3, freeSpaceSourceName(r->source),
                 (unsigned long long)r->thin_cleared, read_s, build_s);
  return kExitOk;
}

}  // namespace adit::tools
