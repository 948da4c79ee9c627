// SPDX-License-Identifier: BSD-3-Clause
// `adit bench global`: the global planner measured on whole maps between roadway ends, per map
// and planner, beside plain OMPL in the whole bounding box (same validity checker) as the
// baseline, with path lengths against the 26-connected grid optimum. Prints a table on stdout
// and writes OMPL's benchmark log format (loadable by ompl_benchmark_statistics.py).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <utility>
#include <unistd.h>

#include "adit/global/global_planner.hpp"
#include "adit/global/grid_reference.hpp"
#include "adit/global/movingai.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "common/cli.hpp"
#include "common/plan_output.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using namespace adit::map;
using global::GlobalPlannerParams;
using global::GlobalPlanResult;

struct BenchArgs {
  std::vector<std::string> maps;  ///< none given: maps/district.yaml, unless --movingai alone
  std::string planners = "rrtconnect,bitstar,informedrrtstar,rrtstar,prmstar";
  std::string robot = "sphere:0.4", mode = "fly", log_dir, json_out, movingai;
  int runs = 2, pairs = 4, movingai_problems = 10, movingai_subdivision = 3;
  double movingai_max_length = 60.0;
  double time_s = 2.0;
  bool no_baseline = false, no_grid = false, quiet = false, no_cache = false;
};

struct Run {
  std::size_t problem = 0;
  int seed = 0;
  GlobalPlanResult result;
  double grid_m = 0.0;  // 0 = unknown
};

struct Variant {
  std::string name;  // planner, or planner + "-bbox" for the baseline
  global::PlannerType planner;
  bool baseline = false;
  std::vector<Run> runs;
};

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const std::size_t i = std::size_t(pos);
  return i + 1 < v.size() ? v[i] + (pos - double(i)) * (v[i + 1] - v[i]) : v[i];
}

// Roadway-end pairs, farthest first; only pairs the graph connects (a scan's free space can fall
// into several parts for the robot, and a pair across two of them has no path to measure).
std::vector<std::pair<Vec3, Vec3>> problems(const global::GlobalPlanner& planner, int count) {
  const global::RoadwayGraph& g = planner.graph();
  const std::vector<int> ends = g.ends();
  std::vector<std::tuple<double, int, int>> pairs;
  for (std::size_t i = 0; i < ends.size(); ++i)
    for (std::size_t j = i + 1; j < ends.size(); ++j)
      pairs.emplace_back(-(g.nodes()[std::size_t(ends[i])].position - g.nodes()[std::size_t(ends[j])].position).norm(),
                         ends[i], ends[j]);
  std::sort(pairs.begin(), pairs.end());
  std::vector<std::pair<Vec3, Vec3>> out;
  const double inset = 2.0 + planner.requiredClearance();
  for (std::size_t k = 0; k < pairs.size() && int(out.size()) < count; ++k) {
    const Vec3 a = g.pointNearEnd(std::get<1>(pairs[k]), inset), b = g.pointNearEnd(std::get<2>(pairs[k]), inset);
    if (g.route(a, b).ok()) out.emplace_back(a, b);
  }
  return out;
}

// OMPL's benchmark log (see OMPL's "benchmark logfile format"): one experiment per map.
bool writeOmplLog(std::ostream& os, const std::string& experiment, const std::string& setup, double time_limit,
                  int runs, double total_s, const std::vector<Variant>& variants) {
  char host[256] = "unknown";
  gethostname(host, sizeof host - 1);
  const std::time_t now = std::time(nullptr);
  char date[64];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S", std::gmtime(&now));
  os << "adit version 0.1.0\n"
     << "Experiment " << experiment << "\n"
     << "Running on " << host << "\n"
     << "Starting at " << date << "\n"
     << "<<<|\n" << setup << "\n|>>>\n"
     << "<<<|\n|>>>\n"
     << "1 is the random seed\n"
     << time_limit << " seconds per run\n"
     << "0 MB per run\n"
     << runs << " runs per planner\n"
     << total_s << " seconds spent to collect the data\n"
     << "0 enum types\n"
     << variants.size() << " planners\n";
  static const char* kProps[] = {"time REAL",          "first path time REAL",      "solved BOOLEAN",
                                 "approximate solution BOOLEAN", "correct solution BOOLEAN", "solution length REAL",
                                 "length ratio to grid optimum REAL", "break points INTEGER", "solution clearance REAL",
                                 "seed INTEGER",       "problem INTEGER"};
  for (const Variant& v : variants) {
    os << "geometric_" << v.name << "\n0 common properties\n" << std::size(kProps) << " properties for each run\n";
    for (const char* p : kProps) os << p << "\n";
    os << v.runs.size() << " runs\n";
    for (const Run& r : v.runs) {
      const GlobalPlanResult& g = r.result;
      const bool ok = g.solved();
      auto real = [&](double x, bool have) { return have && std::isfinite(x) ? std::to_string(x) : std::string(); };
      os << g.planning_time_s << "; " << real(g.first_solution_time_s, ok) << "; " << (ok ? 1 : 0) << "; "
         << (g.outcome == global::GlobalPlanOutcome::kApproximateSolution ? 1 : 0) << "; " << (ok ? "1" : "") << "; "
         << real(g.length_m, ok) << "; " << real(g.length_m / r.grid_m, ok && r.grid_m > 0) << "; "
         << (ok ? std::to_string(g.path.size() - 2) : std::string()) << "; " << real(g.min_clearance_m, ok) << "; "
         << r.seed << "; " << r.problem << "; \n";
    }
    os << ".\n";
  }
  return bool(os);
}

// The MovingAI voxel maps: each problem is planned on a crop that holds every path of at most
// its published optimal length (the bounding box of the ellipsoid with the ends as foci), with a
// small sphere (0.05 voxel, no margin) standing in for the benchmark's point agent. adit keeps
// half a map voxel of conservative clearance; with one map voxel per benchmark voxel that erodes
// the free space by half a voxel, so voxels touching a blocked one are not valid centres. The crop
// is therefore voxelized at --movingai-subdivision map voxels per benchmark voxel edge (3 by
// default: same geometry, a sixth of a voxel rule, every free voxel's centre a valid map voxel
// centre, so one-voxel passages stay passages on the roadway graph too). Endpoints still refused
// are counted ("eroded"), not planned. Peak RSS is measured per map (VmHWM, reset between maps).
// The process's peak resident set since the last reset [MiB], from /proc/self/status (VmHWM);
// resetting writes 5 to /proc/self/clear_refs (Linux). NaN where /proc is not there.
double peakRssMiB(bool reset_after) {
  double kib = std::nan("");
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) kib = std::strtod(line.c_str() + 6, nullptr);
  if (reset_after) std::ofstream("/proc/self/clear_refs") << "5";
  return kib / 1024.0;
}

int runMovingAi(const BenchArgs& a, const std::vector<global::PlannerType>& planners, nlohmann::ordered_json* all) {
  std::vector<std::filesystem::path> maps;
  for (const auto& entry : std::filesystem::directory_iterator(a.movingai))
    if (entry.path().extension() == ".3dmap" && std::filesystem::exists(entry.path().string() + ".3dscen"))
      maps.push_back(entry.path());
  std::sort(maps.begin(), maps.end());
  if (maps.empty()) return report(notFound(a.movingai + ": no .3dmap with a .3dmap.3dscen beside it"));
  if (a.movingai_subdivision < 1 || a.movingai_subdivision > 8)
    return report(invalidArgument("--movingai-subdivision must be 1..8, got " + std::to_string(a.movingai_subdivision)));
  std::printf("\n%-12s %-16s %8s %9s %8s %9s %10s %9s %10s %9s %9s\n", "movingai", "planner", "problems", "eroded",
              "success", "final_ms", "len/grid", "worst", "len/publ", "worst", "peak_MiB");
  for (const auto& map_path : maps) {
    peakRssMiB(true);
    StatusOr<global::MovingAiMap> m = global::loadMovingAiMap(map_path.string());
    if (!m.ok()) return report(m.status());
    StatusOr<std::vector<global::MovingAiProblem>> scen = global::loadMovingAiScenarios(map_path.string() + ".3dscen");
    if (!scen.ok()) return report(scen.status());
    std::vector<global::MovingAiProblem> pick;
    for (const global::MovingAiProblem& p : *scen)
      if (p.optimal_length <= a.movingai_max_length && p.optimal_length >= 10) pick.push_back(p);
    // Evenly spread over the file (which is sorted by length buckets): deterministic.
    std::vector<global::MovingAiProblem> problems;
    for (int i = 0; i < a.movingai_problems && !pick.empty(); ++i)
      problems.push_back(pick[std::size_t(i) * pick.size() / std::size_t(a.movingai_problems)]);
    struct Row {
      int runs = 0, eroded = 0, ok = 0;
      std::vector<double> ms, grid_ratio, publ_ratio;
    };
    std::vector<Row> rows(planners.size());
    for (const global::MovingAiProblem& prob : problems) {
      const auto [lo, hi] = global::movingAiProblemBox(*m, prob);
      StatusOr<OccupancyMap> crop = global::movingAiCrop(*m, lo, hi, 1.0, 2e7, a.movingai_subdivision);
      if (!crop.ok()) return report(crop.status());
      StatusOr<DistanceField> field = DistanceField::build(*crop);
      if (!field.ok()) return report(field.status());
      auto centre = [](const global::VoxelIndex& v) { return Vec3(v[0] + 0.5, v[1] + 0.5, v[2] + 0.5); };
      const Vec3 s = centre(prob.start), g = centre(prob.goal);
      for (std::size_t pi = 0; pi < planners.size(); ++pi) {
        GlobalPlannerParams p;
        p.robot = RobotShape::sphere(0.05);
        p.safety_margin_m = 0.0;
        p.planner = planners[pi];
        p.time_budget_s = a.time_s;
        p.skeleton_cell_m = 2.0;
        StatusOr<global::GlobalPlanner> planner = global::GlobalPlanner::create(*crop, *field, p);
        Row& row = rows[pi];
        ++row.runs;
        if (!planner.ok() || !planner->stateValid(s) || !planner->stateValid(g)) {
          ++row.eroded;
          continue;
        }
        const GlobalPlanResult r = planner->plan(s, g);
        if (!r.solved()) continue;
        ++row.ok;
        row.ms.push_back(1e3 * r.planning_time_s);
        row.publ_ratio.push_back(r.length_m / prob.optimal_length);
        StatusOr<global::GridPathResult> grid =
            global::gridOptimum([&](const Vec3& c) { return planner->stateValid(c); }, 1.0, s, g);
        if (grid.ok() && grid->found) row.grid_ratio.push_back(r.length_m / grid->length_m);
      }
    }
    const std::string name = map_path.filename().string();
    const double peak_mib = peakRssMiB(false);
    for (std::size_t pi = 0; pi < planners.size(); ++pi) {
      const Row& row = rows[pi];
      const int planned = row.runs - row.eroded;
      auto worst = [](const std::vector<double>& v) { return v.empty() ? std::nan("") : *std::max_element(v.begin(), v.end()); };
      const double success = planned > 0 ? double(row.ok) / planned : std::nan("");
      std::printf("%-12s %-16s %8d %9d %7.0f%% %9.1f %10.3f %9.3f %10.3f %9.3f %9.0f\n", name.c_str(),
                  global::plannerTypeName(planners[pi]), row.runs, row.eroded, 100 * success, quantile(row.ms, 0.5),
                  quantile(row.grid_ratio, 0.5), worst(row.grid_ratio), quantile(row.publ_ratio, 0.5), worst(row.publ_ratio), peak_mib);
      all->push_back({{"map", name}, {"planner", global::plannerTypeName(planners[pi])}, {"problems", row.runs},
                      {"endpoints_eroded", row.eroded}, {"success_rate", success},
                      {"final_path_ms_median", quantile(row.ms, 0.5)},
                      {"length_over_grid_median", quantile(row.grid_ratio, 0.5)}, {"length_over_grid_max", worst(row.grid_ratio)},
                      {"length_over_published_median", quantile(row.publ_ratio, 0.5)},
                      {"length_over_published_max", worst(row.publ_ratio)},
                      {"subdivision", a.movingai_subdivision}, {"peak_rss_mib", peak_mib}});
    }
    std::fflush(stdout);
  }
  return kExitOk;
}

int runBench(const BenchArgs& a) {
  StatusOr<RobotShape> robot = parseRobot(a.robot);
  if (!robot.ok()) return report(robot.status());
  StatusOr<global::PlanMode> mode = global::parsePlanMode(a.mode);
  if (!mode.ok()) return report(mode.status());
  std::vector<global::PlannerType> planners;
  {
    std::string list = a.planners;
    std::replace(list.begin(), list.end(), ',', ' ');
    std::istringstream is(list);
    std::string name;
    while (is >> name) {
      StatusOr<global::PlannerType> t = global::parsePlannerType(name);
      if (!t.ok()) return report(t.status());
      planners.push_back(*t);
    }
  }
  if (planners.empty() || a.runs < 1 || a.pairs < 1 || !(a.time_s > 0))
    return report(invalidArgument("need at least one planner, --runs >= 1, --pairs >= 1 and --time > 0"));
  if (!a.log_dir.empty() && !std::filesystem::is_directory(a.log_dir))
    return report(invalidArgument("--log-dir " + a.log_dir + ": not a directory"));

  nlohmann::ordered_json all = nlohmann::ordered_json::array();
  std::vector<std::string> map_paths = a.maps;
  if (map_paths.empty() && a.movingai.empty()) map_paths.push_back("maps/district.yaml");
  bool header = false;  // printed once a map has loaded: a bad first map leaves stdout empty
  for (const std::string& path : map_paths) {
    peakRssMiB(/*reset_after=*/true);  // each map's peak its own
    StatusOr<map::World> world = loadWorld(path, UnknownPolicy::kRock, a.quiet, a.no_cache);
    if (!world.ok()) return report(world.status());
    if (!std::exchange(header, true))
      std::printf("%-22s %-22s %5s %8s %9s %9s %9s %9s %9s %7s %8s %-11s %8s %9s\n", "map", "planner", "runs", "success",
                  "first_ms", "final_ms", "final_p90", "len/grid", "worst", "breaks", "min_clr", "graph", "graph_s",
                  "peak_MiB");
    const LoadedMap* loaded = &world->loaded();
    const DistanceField* field = &world->field();
    const auto t_map = std::chrono::steady_clock::now();
    GlobalPlannerParams base;
    base.robot = *robot;
    base.mode = *mode;
    base.time_budget_s = a.time_s;
    const SurveyNetwork* survey = world->survey();
    // The roadway graph: the survey's, or built from the robot's free space (the time it takes is
    // what a map without a survey costs before its first plan).
    const auto t_graph = std::chrono::steady_clock::now();
    StatusOr<global::GlobalPlanner> reference = global::GlobalPlanner::create(loaded->map, *field, base, survey);
    if (!reference.ok()) return report(reference.status());
    const double graph_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_graph).count();
    const char* graph_kind = survey ? "survey" : "free-space";
    const auto probs = problems(*reference, a.pairs);
    if (probs.empty()) return report(failedPrecondition(path + ": fewer than two roadway ends to plan between"));
    std::vector<double> grid(probs.size(), 0.0);
    if (!a.no_grid) {
      for (std::size_t i = 0; i < probs.size(); ++i) {
        StatusOr<global::GridPathResult> g = global::gridOptimum(
            [&](const Vec3& c) { return reference->stateValid(c); }, loaded->map.resolution(), probs[i].first,
            probs[i].second);
        if (g.ok() && g->found) grid[i] = g->length_m;
        if (!a.quiet)
          std::fprintf(stderr, "problem %zu: (%.1f, %.1f, %.1f) -> (%.1f, %.1f, %.1f), grid optimum %s\n", i,
                       probs[i].first.x(), probs[i].first.y(), probs[i].first.z(), probs[i].second.x(),
                       probs[i].second.y(), probs[i].second.z(),
                       grid[i] > 0 ? (std::to_string(grid[i]) + " m").c_str() : "not found");
      }
    }
    std::vector<Variant> variants;
    for (global::PlannerType t : planners) {
      variants.push_back({global::plannerTypeName(t), t, false, {}});
      if (!a.no_baseline) variants.push_back({std::string(global::plannerTypeName(t)) + "-bbox", t, true, {}});
    }
    for (Variant& v : variants) {
      GlobalPlannerParams p = base;
      p.planner = v.planner;
      p.use_roadway_graph = !v.baseline;
      for (std::size_t i = 0; i < probs.size(); ++i)
        for (int seed = 1; seed <= a.runs; ++seed) {
          // The seed is part of the params (immutable after construction): one planner per seed.
          GlobalPlannerParams ps = p;
          ps.seed = std::uint32_t(seed);
          StatusOr<global::GlobalPlanner> seeded = global::GlobalPlanner::create(loaded->map, *field, ps, survey);
          if (!seeded.ok()) return report(seeded.status());
          v.runs.push_back({i, seed, seeded->plan(probs[i].first, probs[i].second), grid[i]});
          if (!a.quiet)
            std::fprintf(stderr, "%s problem %zu seed %d: %s %.3f s\n", v.name.c_str(), i, seed,
                         global::outcomeName(v.runs.back().result.outcome), v.runs.back().result.planning_time_s);
        }
    }
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_map).count();
    const std::string map_name = std::filesystem::path(path).filename().string();
    const double peak_mib = peakRssMiB(/*reset_after=*/false);
    for (const Variant& v : variants) {
      std::vector<double> first, final_t, ratio, breaks, clear;
      int ok = 0;
      for (const Run& r : v.runs) {
        const GlobalPlanResult& g = r.result;
        if (!g.solved()) continue;
        ++ok;
        first.push_back(1e3 * g.first_solution_time_s);
        final_t.push_back(1e3 * g.planning_time_s);
        if (r.grid_m > 0) ratio.push_back(g.length_m / r.grid_m);
        breaks.push_back(double(g.path.size() - 2));
        clear.push_back(g.min_clearance_m);
      }
      const double success = double(ok) / double(v.runs.size());
      std::printf("%-22s %-22s %5zu %7.0f%% %9.1f %9.1f %9.1f %9.3f %9.3f %7.0f %8.2f %-11s %8.2f %9.0f\n",
                  map_name.c_str(), v.name.c_str(), v.runs.size(), 100 * success, quantile(first, 0.5),
                  quantile(final_t, 0.5), quantile(final_t, 0.9), quantile(ratio, 0.5),
                  ratio.empty() ? std::nan("") : *std::max_element(ratio.begin(), ratio.end()), quantile(breaks, 0.5),
                  clear.empty() ? std::nan("") : *std::min_element(clear.begin(), clear.end()), graph_kind, graph_s,
                  peak_mib);
      all.push_back({{"map", map_name}, {"planner", v.name}, {"baseline", v.baseline}, {"runs", v.runs.size()},
                     {"success_rate", success}, {"first_path_ms_median", quantile(first, 0.5)},
                     {"final_path_ms_median", quantile(final_t, 0.5)}, {"final_path_ms_p90", quantile(final_t, 0.9)},
                     {"length_over_grid_median", quantile(ratio, 0.5)},
                     {"length_over_grid_max", ratio.empty() ? std::nan("") : *std::max_element(ratio.begin(), ratio.end())},
                     {"break_points_median", quantile(breaks, 0.5)},
                     {"min_clearance", clear.empty() ? std::nan("") : *std::min_element(clear.begin(), clear.end())},
                     {"graph", graph_kind}, {"graph_build_s", graph_s}, {"peak_rss_mib", peak_mib}});
    }
    std::fflush(stdout);
    if (!a.log_dir.empty()) {
      const std::string log = (std::filesystem::path(a.log_dir) / ("adit_global_" + map_name + ".log")).string();
      std::ostringstream setup;
      setup << "map " << path << ", robot " << robot->name() << ", mode " << a.mode << ", " << probs.size()
            << " problems between roadway ends; *-bbox = plain OMPL sampling the whole bounding box";
      Status s = writeFileAtomically(
          log, [&](std::ostream& os) { return writeOmplLog(os, "adit-global-" + map_name, setup.str(), a.time_s, a.runs, total, variants); });
      if (!s.ok()) return report(s);
      if (!a.quiet) std::fprintf(stderr, "wrote %s\n", log.c_str());
    }
  }
  if (!a.movingai.empty()) {
    const int rc = runMovingAi(a, planners, &all);
    if (rc != kExitOk) return rc;
  }
  if (!a.json_out.empty()) {
    Status s = writeFileAtomically(a.json_out, [&](std::ostream& os) { return bool(os << all.dump(2) << "\n"); });
    if (!s.ok()) return report(s);
  }
  return kExitOk;
}

}  // namespace

void registerBenchVerb(CLI::App& app, int* rc) {
  CLI::App* bench = app.add_subcommand("bench", "Measure the planners (ratios against baselines run side by side)");
  bench->require_subcommand(1);
  auto a = std::make_shared<BenchArgs>();
  CLI::App* cmd = bench->add_subcommand(
      "global",
      "Global planner per map and planner between roadway ends: success rate, first/final path time,\n"
      "length / grid optimum, break points, minimum clearance; beside plain OMPL sampling the whole\n"
      "bounding box (\"-bbox\", same validity checker). Table on stdout; --log-dir writes OMPL's\n"
      "benchmark log format (ompl_benchmark_statistics.py, Planner Arena).");
  cmd->add_option("--map", a->maps,
                  "Maps (.yaml/.bt/.ot); repeat for several (default maps/district.yaml unless only --movingai)");
  cmd->add_option("--planners", a->planners, "Comma-separated planner names")->capture_default_str();
  cmd->add_option("--runs", a->runs, "Seeds per problem")->capture_default_str();
  cmd->add_option("--pairs", a->pairs, "Roadway-end pairs per map, farthest first")->capture_default_str();
  cmd->add_option("--time", a->time_s, "Time budget per plan [s]")->capture_default_str();
  cmd->add_option("--robot", a->robot, "sphere:r | capsule:r,len | box:x,y,z | cylinder:r,h")->capture_default_str();
  cmd->add_option("--mode", a->mode, "fly or ground")->capture_default_str()->check(CLI::IsMember({"fly", "ground"}));
  cmd->add_option("--log-dir", a->log_dir, "Write adit_global_<map>.log (OMPL benchmark format) here");
  cmd->add_option("--json", a->json_out, "Also write the table as JSON to this file");
  cmd->add_option("--movingai", a->movingai,
                  "Also the MovingAI 3-D voxel benchmark maps in this directory (*.3dmap + *.3dmap.3dscen)");
  cmd->add_option("--movingai-problems", a->movingai_problems, "Problems per MovingAI map")->capture_default_str();
  cmd->add_option("--movingai-subdivision", a->movingai_subdivision,
                  "Map voxels per MovingAI voxel edge (1..8): 3 lets the point agent stand beside a blocked voxel and pass one-voxel gaps")
      ->capture_default_str();
  cmd->add_option("--movingai-max-length", a->movingai_max_length,
                  "Only MovingAI problems with a published optimum up to this many voxels")->capture_default_str();
  cmd->add_flag("--no-baseline", a->no_baseline, "Skip plain OMPL in the bounding box");
  cmd->add_flag("--no-grid", a->no_grid, "Skip the grid optimum (no length ratios)");
  cmd->add_flag("--no-cache", a->no_cache, "Build the map's octree and distance field afresh: neither read nor write the map cache");
  cmd->add_flag("-q,--quiet", a->quiet, "No progress output");
  cmd->callback([=] { *rc = runBench(*a); });
}

}  // namespace adit::tools
