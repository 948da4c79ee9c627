// SPDX-License-Identifier: BSD-3-Clause
// `adit plan`: the expected path from a start to a goal. Thin: parse, load, call
// adit::global::GlobalPlanner, write JSON/CSV and the picture.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>

#include "adit/fusion/plan_refinement.hpp"
#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "common/cli.hpp"
#include "common/points_csv.hpp"
#include "common/figure.hpp"
#include "common/phase_times.hpp"
#include "common/plan_output.hpp"
#include "verbs.hpp"

namespace adit::tools {

namespace {

using namespace adit::map;
using adit::global::GlobalPlannerParams;
using adit::global::GlobalPlanResult;

struct PlanArgs {
  std::string map_path, start, goal, robot = "sphere:0.4", mode = "fly", planner = "bitstar";
  std::string unknown = "rock", out, picture, max_memory;
  double time_s = 2.0, margin = 0.2, clearance_weight = 0.05, max_slope = 15.0;
  int seed = 1, iterations = 1500;
  bool quiet = false, farthest_ends = false, refine = false, no_cache = false;
};

StatusOr<GlobalPlannerParams> paramsFrom(const PlanArgs& a) {
  GlobalPlannerParams p;
  ADIT_ASSIGN_OR_RETURN(p.robot, parseRobot(a.robot));
  ADIT_ASSIGN_OR_RETURN(p.mode, global::parsePlanMode(a.mode));
  ADIT_ASSIGN_OR_RETURN(p.planner, global::parsePlannerType(a.planner));
  if (a.seed < 0) return invalidArgument("--seed must be >= 0, got " + std::to_string(a.seed));
  p.time_budget_s = a.time_s;
  p.seed = std::uint32_t(a.seed);
  p.max_iterations = a.iterations;
  p.safety_margin_m = a.margin;
  p.clearance_weight = a.clearance_weight;
  p.max_slope_deg = a.max_slope;
  ADIT_ASSIGN_OR_RETURN(p.max_graph_memory_bytes, memoryBudgetOf(a.max_memory));
  ADIT_RETURN_IF_ERROR(p.validate());
  return p;
}

int exitCodeFor(const GlobalPlanResult& r) {
  using global::GlobalPlanOutcome;
  if (r.solved()) return kExitOk;
  if (global::isInvalidEndpoint(r.outcome)) return kExitBadInput;
  if (r.outcome == GlobalPlanOutcome::kError) return kExitFailure;
  return kExitNoPath;
}

// --refine: the genetic trust-region break-point refinement of the planned path (shared with the
// Navigator, adit/fusion/plan_refinement.hpp). `r` becomes the refined path (or stays, if the
// refiner keeps the input); the returned info holds the unrefined figures.
PlanRefinementInfo refinePlan(const global::GlobalPlanner& planner, const DistanceField& field, GlobalPlanResult* r,
                              bool quiet) {
  const fusion::PlanRefinement ref = fusion::refinePlan(planner, field, r);
  PlanRefinementInfo info;
  info.time_s = ref.time_s;
  info.length_m = ref.before.length_m;
  info.min_clearance_m = ref.before.min_clearance_m;
  info.mean_clearance_m = ref.before.mean_clearance_m;
  info.path = ref.before_path;
  info.outcome = fusion::refineOutcomeName(ref.outcome);
  info.message = ref.message;
  info.iterations = ref.iterations;
  if (!quiet) std::fprintf(stderr, "refine: %s: %s (%.3f s)\n", info.outcome.c_str(), ref.message.c_str(), info.time_s);
  return info;
}

int runPlan(const PlanArgs& a) {
  PhaseTimes phases;
  // Everything about the request is checked before the (possibly long) map load.
  if (a.farthest_ends == (!a.start.empty() || !a.goal.empty()) || (!a.farthest_ends && (a.start.empty() || a.goal.empty())))
    return report(invalidArgument("give --start and --goal, or --farthest-ends (not both)"));
  StatusOr<Vec3> start = a.farthest_ends ? StatusOr<Vec3>(Vec3::Zero()) : parsePoint(a.start, "--start");
  if (!start.ok()) return report(start.status());
  StatusOr<Vec3> goal = a.farthest_ends ? StatusOr<Vec3>(Vec3::Zero()) : parsePoint(a.goal, "--goal");
  if (!goal.ok()) return report(goal.status());
  StatusOr<GlobalPlannerParams> params = paramsFrom(a);
  if (!params.ok()) return report(params.status());
  StatusOr<UnknownPolicy> policy = parseUnknownPolicy(a.unknown);
  if (!policy.ok()) return report(policy.status());
  if (!a.out.empty()) {
    StatusOr<PlanFormat> f = planFormatFromPath(a.out);
    if (!f.ok()) return report(f.status());
  }
  if (!a.picture.empty()) {
    const std::string ext = std::filesystem::path(a.picture).extension().string();
    if (ext != ".png" && ext != ".svg" && ext != ".PNG" && ext != ".SVG")
      return report(invalidArgument("--picture " + a.picture + ": expected a .png or .svg file"));
  }
  // Both outputs writable before anything is written: a bad --picture must not leave --out behind.
  if (Status s = checkOutputPath(a.out, "--out"); !s.ok()) return report(s);
  if (Status s = checkOutputPath(a.picture, "--picture"); !s.ok()) return report(s);

  phases.mark("arguments");
  StatusOr<map::World> world = loadWorld(a.map_path, *policy, a.quiet, a.no_cache, params->max_graph_memory_bytes);
  if (!world.ok()) return report(world.status());
  phases.mark("map other");
  phases.splitWorld("map other", world->times());
  const LoadedMap* loaded = &world->loaded();
  StatusOr<global::GlobalPlanner> planner =
      global::GlobalPlanner::create(loaded->map, world->field(), *params, world->survey());
  if (!planner.ok()) return report(planner.status());
  if (a.farthest_ends) {
    const auto ends = planner->graph().farthestEnds();
    if (!ends) return report(failedPrecondition(a.map_path + ": the roadway graph has fewer than two roadway ends"));
    // A few metres in from each face, where the robot fits.
    const double inset = 2.0 + planner->requiredClearance();
    *start = planner->graph().pointNearEnd(ends->first, inset);
    *goal = planner->graph().pointNearEnd(ends->second, inset);
    if (!a.quiet)
      std::fprintf(stderr, "farthest roadway ends: %s (%.1f, %.1f, %.1f) and %s (%.1f, %.1f, %.1f)\n",
                   planner->graph().nodes()[std::size_t(ends->first)].name.c_str(), start->x(), start->y(), start->z(),
                   planner->graph().nodes()[std::size_t(ends->second)].name.c_str(), goal->x(), goal->y(), goal->z());
  }

  phases.mark("roadway graph");
  GlobalPlanResult r = planner->plan(*start, *goal);
  const int code = exitCodeFor(r);
  if (!r.solved()) std::fprintf(stderr, "adit: %s: %s\n", global::outcomeName(r.outcome), r.message.c_str());
  std::optional<PlanRefinementInfo> refined;
  if (a.refine && r.solved()) refined = refinePlan(*planner, world->field(), &r, a.quiet);
  const PlanRefinementInfo* before = refined ? &*refined : nullptr;
  phases.mark("planning");

  if (!a.out.empty()) {
    Status s = writePlan(r, a.out, before);
    if (!s.ok()) return report(s);
  } else {
    std::printf("%s\n", planJson(r, before).dump(2).c_str());
  }
  TopViewInfo picture_info;
  if (!a.picture.empty()) {
    const std::string name = loaded->survey && !loaded->survey->name.empty()
                                 ? loaded->survey->name
                                 : std::filesystem::path(a.map_path).filename().string();
    Status s = drawPlan(loaded->map, planner->graph(), r, *start, *goal, "adit plan: " + name, a.picture,
                        before ? &before->path : nullptr, &picture_info);
    if (!s.ok()) return report(s);
  }
  if (!a.quiet) {
    // A failure was said once already, above (even with --quiet).
    if (r.solved())
      std::fprintf(stderr, "%s: %s (%s, %.3f s)\n", global::outcomeName(r.outcome), r.message.c_str(), r.planner.c_str(),
                   r.planning_time_s);
    if (!a.out.empty()) std::fprintf(stderr, "wrote %s\n", a.out.c_str());
    if (!a.picture.empty())
      std::fprintf(stderr, "wrote %s (%zu labels, %zu markers in merged labels, %zu leader lines, %zu overlapping)\n",
                   a.picture.c_str(), picture_info.labels, picture_info.labels_merged, picture_info.label_leaders,
                   picture_info.label_overlaps);
  }
  phases.mark("output");
  // Freed here, not at exit, so that the time line says what freeing the world costs.
  planner = internalError("freed");
  world = internalError("freed");
  phases.mark("teardown");
  if (!a.quiet) phases.print();
  return code;
}

}  // namespace

void registerPlanVerb(CLI::App& app, int* rc) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* cmd = app.add_subcommand(
      "plan",
      "The expected path (a polyline with break points A, B, ...) from --start to --goal: routed on the\n"
      "roadway graph, planned by OMPL inside that route's corridor, shortened and re-validated.\n"
      "Exit codes: 0 path found, 1 failure, 2 bad input (start/goal in rock or outside the map, bad\n"
      "option or map), 3 no path (reason on stderr and in the JSON).");
  cmd->add_option("--map", a->map_path, "Map: survey network .yaml, OctoMap .bt or .ot")->required();
  cmd->add_option("--start", a->start, "Start x,y,z [m]");
  cmd->add_option("--goal", a->goal, "Goal x,y,z [m]");
  cmd->add_flag("--farthest-ends", a->farthest_ends,
                "Instead of --start/--goal: between the two roadway ends farthest apart");
  cmd->add_option("--robot", a->robot, "sphere:r | capsule:r,len | box:x,y,z | cylinder:r,h  [m]")->capture_default_str();
  cmd->add_option("--mode", a->mode, "fly (free in 3-D) or ground (on the floor, slope-limited)")->capture_default_str()
      ->check(CLI::IsMember({"fly", "ground"}));
  cmd->add_option("--planner", a->planner, "rrtconnect, rrtstar, informedrrtstar, bitstar, prmstar")->capture_default_str();
  cmd->add_option("--time", a->time_s, "Time budget of the search [s]")->capture_default_str();
  cmd->add_option("--seed", a->seed, "Random seed: same inputs and seed give the same path")->capture_default_str();
  cmd->add_option("--iterations", a->iterations, "Anytime planners stop after this many iterations once solved")->capture_default_str();
  cmd->add_option("--margin", a->margin, "Safety margin kept from rock beyond the robot [m]")->capture_default_str();
  cmd->add_option("--clearance-weight", a->clearance_weight, "Weight of the clearance penalty in the cost (0 = length)")->capture_default_str();
  cmd->add_option("--max-slope", a->max_slope, "Ground mode: steepest floor the robot climbs [deg]")->capture_default_str();
  cmd->add_option("--unknown", a->unknown, "Unknown space counts as: rock (default) or free")->capture_default_str()
      ->check(CLI::IsMember({"rock", "free"}));
  cmd->add_option("-o,--out", a->out, "Write the result to a .json or .csv file (default: JSON on stdout)");
  cmd->add_option("--picture", a->picture, "Draw the map, path, break points and side profile (.png/.svg)");
  cmd->add_flag("--refine", a->refine,
                "Refine the break points jointly (genetic trust region): minimise length + --clearance-weight x\n"
                "the clearance penalty along the path, every segment re-validated;\n"
                "the JSON gains \"before\" (unrefined length, clearances, path) and \"refine\"");
  cmd->add_flag("--no-cache", a->no_cache, "Build the map's octree and distance field afresh: neither read nor write the map cache");
  cmd->add_option("--max-memory", a->max_memory, maxMemoryHelp("loading the map, its distance field and roadway graph"));
  cmd->add_flag("-q,--quiet", a->quiet, "No progress output");
  cmd->callback([=] { *rc = runPlan(*a); });
}

}  // namespace adit::tools
