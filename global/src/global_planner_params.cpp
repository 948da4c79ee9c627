// SPDX-License-Identifier: BSD-3-Clause
#include "adit/global/global_planner_params.hpp"

#include <cctype>
#include <cmath>
#include <sstream>

namespace adit::global {

const char* planModeName(PlanMode m) { return m == PlanMode::kFly ? "fly" : "ground"; }

StatusOr<PlanMode> parsePlanMode(const std::string& name) {
  if (name == "fly") return PlanMode::kFly;
  if (name == "ground") return PlanMode::kGround;
  return invalidArgument("unknown mode '" + name + "' (expected fly or ground)");
}

namespace {
struct PlannerName {
  PlannerType type;
  const char* name;
};
constexpr PlannerName kPlannerNames[] = {
    {PlannerType::kRrtConnect, "rrtconnect"},     {PlannerType::kRrtStar, "rrtstar"},
    {PlannerType::kInformedRrtStar, "informedrrtstar"}, {PlannerType::kBitStar, "bitstar"},
    {PlannerType::kPrmStar, "prmstar"},
};

Status positiveFinite(const char* field, double v) {
  if (std::isfinite(v) && v > 0) return {};
  std::ostringstream m;
  m << "GlobalPlannerParams::" << field << " = " << v << " must be finite and > 0";
  return invalidArgument(m.str());
}
Status nonNegativeFinite(const char* field, double v) {
  if (std::isfinite(v) && v >= 0) return {};
  std::ostringstream m;
  m << "GlobalPlannerParams::" << field << " = " << v << " must be finite and >= 0";
  return invalidArgument(m.str());
}
}  // namespace

const char* plannerTypeName(PlannerType p) {
  for (const PlannerName& n : kPlannerNames)
    if (n.type == p) return n.name;
  return "?";
}

StatusOr<PlannerType> parsePlannerType(const std::string& name) {
  std::string lower;
  for (char c : name) lower += char(std::tolower(static_cast<unsigned char>(c)));
  for (const PlannerName& n : kPlannerNames)
    if (lower == n.name) return n.type;
  return invalidArgument("unknown planner '" + name +
                         "' (expected rrtconnect, rrtstar, informedrrtstar, bitstar or prmstar)");
}

bool isAnytime(PlannerType p) { return p != PlannerType::kRrtConnect; }

Status GlobalPlannerParams::validate() const {
  if (Status s = robot.validate(); !s.ok()) return invalidArgument("GlobalPlannerParams::robot: " + s.message());
  ADIT_RETURN_IF_ERROR(positiveFinite("time_budget_s", time_budget_s));
  // The deadline is a steady_clock time point in nanoseconds: beyond about 290 years it overflows
  // and the search would stop at once ("no path" after a millisecond). A week is far beyond any
  // plan's need and far from that limit.
  if (time_budget_s > kMaxTimeBudgetS) {
    std::ostringstream os;
    os << "GlobalPlannerParams::time_budget_s = " << time_budget_s << " must be <= " << kMaxTimeBudgetS << " s (a week)";
    return invalidArgument(os.str());
  }
  if (max_iterations < 1) return invalidArgument("GlobalPlannerParams::max_iterations = " + std::to_string(max_iterations) + " must be >= 1");
  if (max_unsolved_iterations < 0)
    return invalidArgument("GlobalPlannerParams::max_unsolved_iterations = " + std::to_string(max_unsolved_iterations) +
                           " must be >= 0 (0: no cap)");
  ADIT_RETURN_IF_ERROR(nonNegativeFinite("safety_margin_m", safety_margin_m));
  ADIT_RETURN_IF_ERROR(nonNegativeFinite("clearance_weight", clearance_weight));
  ADIT_RETURN_IF_ERROR(positiveFinite("preferred_clearance_m", preferred_clearance_m));
  ADIT_RETURN_IF_ERROR(positiveFinite("motion_step_voxels", motion_step_voxels));
  if (motion_step_voxels > 1.0) {
    std::ostringstream m;
    m << "GlobalPlannerParams::motion_step_voxels = " << motion_step_voxels
      << " must be <= 1 (a coarser step could jump a one-voxel wall)";
    return invalidArgument(m.str());
  }
  ADIT_RETURN_IF_ERROR(positiveFinite("max_slope_deg", max_slope_deg));
  if (max_slope_deg >= 90.0) return invalidArgument("GlobalPlannerParams::max_slope_deg = " + std::to_string(max_slope_deg) + " must be < 90");
  ADIT_RETURN_IF_ERROR(positiveFinite("slope_baseline_m", slope_baseline_m));
  ADIT_RETURN_IF_ERROR(positiveFinite("ground_tolerance_m", ground_tolerance_m));
  ADIT_RETURN_IF_ERROR(positiveFinite("skeleton_cell_m", skeleton_cell_m));
  return {};
}

}  // namespace adit::global
