// SPDX-License-Identifier: BSD-3-Clause
// The OMPL adapter: the only file that includes OMPL. It turns a route's corridor and
// RobotValidity into an OMPL problem, runs the chosen planner under a deterministic termination
// rule, and post-processes the path (OMPL's PathSimplifier, then adit's shortcutting and
// break-point relaxation), re-validating every segment after every step.
#include "adit/global/global_planner.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <sstream>

#include <ompl/base/MotionValidator.h>
#include <ompl/base/OptimizationObjective.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/StateSampler.h>
#include <ompl/base/goals/GoalState.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/informedtrees/BITstar.h>
#include <ompl/geometric/planners/prm/PRMstar.h>
#include <ompl/geometric/planners/rrt/InformedRRTstar.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/geometric/planners/rrt/RRTstar.h>
#include <ompl/util/Console.h>
#include <ompl/util/Exception.h>
#include <ompl/util/RandomNumbers.h>

#include "adit/map/collision.hpp"
#include "corridor.hpp"
#include "robot_validity.hpp"

namespace adit::global {

namespace ob = ompl::base;
namespace og = ompl::geometric;
using map::Polyline;
using map::Vec3;
using Clock = std::chrono::steady_clock;

const char* outcomeName(GlobalPlanOutcome o) {
  switch (o) {
    case GlobalPlanOutcome::kExactSolution: return "exact";
    case GlobalPlanOutcome::kApproximateSolution: return "approximate";
    case GlobalPlanOutcome::kStartInRock: return "start_in_rock";
    case GlobalPlanOutcome::kGoalInRock: return "goal_in_rock";
    case GlobalPlanOutcome::kStartUnknown: return "start_unknown";
    case GlobalPlanOutcome::kGoalUnknown: return "goal_unknown";
    case GlobalPlanOutcome::kStartOutsideMap: return "start_outside_map";
    case GlobalPlanOutcome::kGoalOutsideMap: return "goal_outside_map";
    case GlobalPlanOutcome::kTimeout: return "timeout";
    case GlobalPlanOutcome::kNoPath: return "no_path";
    case GlobalPlanOutcome::kError: return "error";
  }
  return "?";
}

bool isInvalidEndpoint(GlobalPlanOutcome o) {
  switch (o) {
    case GlobalPlanOutcome::kStartInRock:
    case GlobalPlanOutcome::kGoalInRock:
    case GlobalPlanOutcome::kStartUnknown:
    case GlobalPlanOutcome::kGoalUnknown:
    case GlobalPlanOutcome::kStartOutsideMap:
    case GlobalPlanOutcome::kGoalOutsideMap: return true;
    default: return false;
  }
}

namespace {

Vec3 toVec(const ob::State* s) {
  const double* v = s->as<ob::RealVectorStateSpace::StateType>()->values;
  return {v[0], v[1], v[2]};
}
void fromVec(const Vec3& p, ob::State* s) {
  double* v = s->as<ob::RealVectorStateSpace::StateType>()->values;
  v[0] = p.x(), v[1] = p.y(), v[2] = p.z();
}

std::string fmt(const Vec3& p) {
  std::ostringstream o;
  o.precision(2);
  o << std::fixed << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return o.str();
}

// Ground mode: a point moved onto the floor (half-height above it) near the given height.
std::optional<Vec3> snap(const RobotValidity& v, const Vec3& p, double search_up) {
  if (!v.ground()) return p;
  return v.onFloor(p + Vec3(0, 0, search_up), search_up + v.halfHeight() + 2.0);
}

// Draws from the corridor (never the whole bounding box); ground mode puts samples on the floor.
class CorridorSampler : public ob::StateSampler {
 public:
  CorridorSampler(const ob::StateSpace* space, const Corridor& corridor, const RobotValidity& validity,
                  std::uint64_t seed)
      : ob::StateSampler(space), corridor_(corridor), validity_(validity), rng_(seed) {}

  void sampleUniform(ob::State* state) override {
    Vec3 p;
    // Inside a corridor a few tries find a free point (the rest of the corridor is rock); the
    // box sampler of the ground-mode baseline draws once, as OMPL's would.
    const int attempts = corridor_.isBox() ? 1 : 16;
    for (int attempt = 0; attempt < attempts; ++attempt) {
      Vec3 axis;
      p = corridor_.sample(rng_, &axis);
      if (validity_.ground()) {
        const double depth = (corridor_.isBox() ? corridor_.bounds().size().z() : 2.0 * (axis - p).norm()) + 2.0;
        const std::optional<Vec3> q = validity_.onFloor(Vec3(p.x(), p.y(), axis.z()), depth);
        if (!q) continue;
        p = *q;
      }
      if (validity_.stateValid(p)) break;
    }
    fromVec(p, state);
  }
  void sampleUniformNear(ob::State* state, const ob::State* near, double distance) override {
    std::uniform_real_distribution<double> u(-distance, distance);
    place(toVec(near) + Vec3(u(rng_), u(rng_), u(rng_)), distance, state);
  }
  void sampleGaussian(ob::State* state, const ob::State* mean, double stddev) override {
    std::normal_distribution<double> n(0.0, stddev);
    place(toVec(mean) + Vec3(n(rng_), n(rng_), n(rng_)), 3 * stddev, state);
  }

 private:
  void place(Vec3 p, double spread, ob::State* state) {
    if (validity_.ground()) {
      if (std::optional<Vec3> q = snap(validity_, p, spread)) p = *q;
    }
    fromVec(p, state);
    space_->enforceBounds(state);
  }
  const Corridor& corridor_;
  const RobotValidity& validity_;
  std::mt19937_64 rng_;
};

class MotionCheck : public ob::MotionValidator {
 public:
  MotionCheck(const ob::SpaceInformationPtr& si, const RobotValidity& validity)
      : ob::MotionValidator(si), validity_(validity) {}
  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    const bool ok = si_->isValid(s2) && validity_.motionValid(toVec(s1), toVec(s2));
    (ok ? valid_ : invalid_)++;
    return ok;
  }
  bool checkMotion(const ob::State* s1, const ob::State* s2, std::pair<ob::State*, double>& last) const override {
    double f = 1.0;
    const bool ok = validity_.motionValid(toVec(s1), toVec(s2), &f) && si_->isValid(s2);
    if (!ok) {
      f = std::min(f, 1.0 - 1e-9);
      if (last.first) si_->getStateSpace()->interpolate(s1, s2, f, last.first);
      last.second = f;
    }
    (ok ? valid_ : invalid_)++;
    return ok;
  }

 private:
  const RobotValidity& validity_;
};

// Length weighted by a clearance penalty (RobotValidity::segmentCost); the Euclidean length is
// an admissible heuristic for it, which the informed planners need.
class ClearanceObjective : public ob::OptimizationObjective {
 public:
  ClearanceObjective(const ob::SpaceInformationPtr& si, const RobotValidity& validity)
      : ob::OptimizationObjective(si), validity_(validity) {
    description_ = "length + clearance penalty";
    setCostToGoHeuristic(&ob::goalRegionCostToGo);
  }
  ob::Cost stateCost(const ob::State*) const override { return identityCost(); }
  ob::Cost motionCost(const ob::State* s1, const ob::State* s2) const override {
    return ob::Cost(validity_.segmentCost(toVec(s1), toVec(s2)));
  }
  ob::Cost motionCostHeuristic(const ob::State* s1, const ob::State* s2) const override {
    return ob::Cost(si_->distance(s1, s2));
  }

 private:
  const RobotValidity& validity_;
};

// Greedy shortcutting: from each kept vertex jump to the farthest later vertex that is reachable
// by a valid straight segment no costlier than the path it replaces. Deterministic. Costs of the
// path between vertices come from prefix sums, so a long path costs O(n^2) segment tests at most.
std::vector<Vec3> shortcut(const RobotValidity& v, const std::vector<Vec3>& p) {
  if (p.size() < 3) return p;
  std::vector<double> prefix(p.size(), 0.0);
  for (std::size_t k = 0; k + 1 < p.size(); ++k) prefix[k + 1] = prefix[k] + v.segmentCost(p[k], p[k + 1]);
  std::vector<Vec3> out{p.front()};
  std::size_t i = 0;
  while (i + 1 < p.size()) {
    std::size_t next = i + 1;
    for (std::size_t j = p.size() - 1; j > i + 1; --j) {
      if (v.motionValid(p[i], p[j]) && v.segmentCost(p[i], p[j]) <= prefix[j] - prefix[i] + 1e-12) {
        next = j;
        break;
      }
    }
    out.push_back(p[next]);
    i = next;
  }
  return out;
}

// Pulls each break point toward the straight line between its neighbours (bisection on the
// step) while both segments stay valid and the cost drops, and drops break points that became
// unnecessary: the path tightens around the corners at the required clearance.
std::vector<Vec3> relax(const RobotValidity& v, std::vector<Vec3> p, int passes) {
  auto total = [&] {
    double c = 0;
    for (std::size_t k = 0; k + 1 < p.size(); ++k) c += v.segmentCost(p[k], p[k + 1]);
    return c;
  };
  double cost = total();
  for (int pass = 0; pass < passes; ++pass) {
    bool changed = false;
    for (std::size_t k = 1; k + 1 < p.size(); ++k) {
      const Vec3 a = p[k - 1], b = p[k + 1];
      const double before = v.segmentCost(a, p[k]) + v.segmentCost(p[k], b);
      // A centimetre of slack: the clearance penalty is sampled per metre, so a break point on a
      // straight line could otherwise survive on sampling noise alone.
      if (v.segmentCost(a, b) <= before + 0.01 && v.motionValid(a, b)) {
        p.erase(p.begin() + std::ptrdiff_t(k));
        --k;
        changed = true;
        continue;
      }
      const Vec3 d = b - a;
      const double t = d.squaredNorm() > 0 ? std::clamp((p[k] - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.5;
      const Vec3 target = a + t * d;
      for (double alpha = 0.5; alpha > 1.0 / 64; alpha *= 0.5) {
        const std::optional<Vec3> q = snap(v, p[k] + alpha * (target - p[k]), 0.3);
        if (!q) continue;
        const double after = v.segmentCost(a, *q) + v.segmentCost(*q, b);
        if (after < before - 1e-6 && v.motionValid(a, *q) && v.motionValid(*q, b)) {
          p[k] = *q;
          changed = true;
          break;
        }
      }
    }
    // Converged when a whole pass gains less than a millimetre.
    const double now = total();
    if (!changed || cost - now < 1e-3) break;
    cost = now;
  }
  return p;
}

// Break points a couple of metres apart (a taut path rounding a corner at the required
// clearance) are replaced by one, where the segments before and after them would meet, when that
// stays valid and costs at most `max_extra` more: fewer sub-goals for the local planner.
std::vector<Vec3> mergeCloseBreakPoints(const RobotValidity& v, std::vector<Vec3> p, double max_gap, double max_extra) {
  bool changed = true;
  while (changed) {
    changed = false;
    for (std::size_t k = 1; k + 2 < p.size(); ++k) {
      if ((p[k + 1] - p[k]).norm() > max_gap) continue;
      const Vec3 a = p[k - 1], b = p[k + 2];
      // Closest point between the lines a->p[k] and b->p[k+1] (midpoint of the common normal).
      const Vec3 d1 = p[k] - a, d2 = p[k + 1] - b, r = a - b;
      const double aa = d1.dot(d1), bb = d1.dot(d2), cc = d2.dot(d2), dd = d1.dot(r), ee = d2.dot(r);
      const double den = aa * cc - bb * bb;
      Vec3 meet = 0.5 * (p[k] + p[k + 1]);
      if (den > 1e-12 * aa * cc) {
        const double t1 = (bb * ee - cc * dd) / den, t2 = (aa * ee - bb * dd) / den;
        if (t1 > 0 && t2 > 0) meet = 0.5 * ((a + t1 * d1) + (b + t2 * d2));
      }
      const std::optional<Vec3> q = snap(v, meet, 0.3);
      if (!q || (*q - meet).norm() > max_gap) continue;
      const double before = v.segmentCost(a, p[k]) + v.segmentCost(p[k], p[k + 1]) + v.segmentCost(p[k + 1], b);
      if (v.segmentCost(a, *q) + v.segmentCost(*q, b) > before + max_extra) continue;
      if (!v.motionValid(a, *q) || !v.motionValid(*q, b)) continue;
      p[k] = *q;
      p.erase(p.begin() + std::ptrdiff_t(k) + 1);
      changed = true;
    }
  }
  return p;
}

// Midpoints on long segments give the relaxation room to bend the path around curved roadways.
std::vector<Vec3> subdivide(const RobotValidity& v, const std::vector<Vec3>& p, double max_len) {
  std::vector<Vec3> out{p.front()};
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const int n = std::max(1, int(std::ceil((p[i + 1] - p[i]).norm() / max_len)));
    for (int k = 1; k < n; ++k) {
      const Vec3 m = p[i] + (p[i + 1] - p[i]) * (double(k) / n);
      const std::optional<Vec3> q = snap(v, m, 0.3);
      out.push_back(q ? *q : m);
    }
    out.push_back(p[i + 1]);
  }
  return out;
}

Status validatePoints(const RobotValidity& v, const std::vector<Vec3>& p, bool turns = true);

// adit's own shortening of a valid path (a search's, or the route's axis): shortcuts and
// break-point relaxation, each step's result kept only when every segment re-validates.
std::vector<Vec3> polish(const RobotValidity& v, std::vector<Vec3> best) {
  // A headed box's path may keep no more break points it cannot turn at than it had.
  auto accept = [&](std::vector<Vec3> candidate) {
    if (candidate.size() >= 2 && candidate.front() == best.front() && candidate.back() == best.back() &&
        validatePoints(v, candidate, false).ok() && v.badTurns(candidate) <= v.badTurns(best))
      best = std::move(candidate);
  };
  accept(shortcut(v, best));
  accept(relax(v, subdivide(v, best, 4.0), 40));
  accept(shortcut(v, best));
  accept(relax(v, best, 40));
  accept(mergeCloseBreakPoints(v, best, 3.0, 0.05));
  return best;
}

Status validatePoints(const RobotValidity& v, const std::vector<Vec3>& p, bool turns) {
  if (p.empty()) return invalidArgument("empty path");
  if (p.size() == 1 && !v.stateValid(p[0])) return invalidArgument("the single point " + fmt(p[0]) + " is not valid");
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    double f = 1.0;
    if (!v.motionValid(p[i], p[i + 1], &f)) {
      const Vec3 where = p[i] + f * (p[i + 1] - p[i]);
      return invalidArgument("segment " + std::to_string(i) + " from " + fmt(p[i]) + " to " + fmt(p[i + 1]) +
                             " is not valid near " + fmt(where));
    }
  }
  if (!v.pathSlopeValid(p)) return invalidArgument("the path climbs a floor steeper than the slope limit");
  std::size_t at = 0;
  if (turns && v.badTurns(p, &at) > 0)
    return invalidArgument("the robot's box cannot turn at break point " + std::to_string(at) + " " + fmt(p[at]) +
                           " from the heading of the segment before it to the one after it");
  return {};
}

}  // namespace

struct GlobalPlanner::Impl {
  const map::OccupancyMap* map;
  const map::DistanceField* field;
  map::CollisionChecker checker;
  GlobalPlannerParams params;
  std::unique_ptr<RobotValidity> validity;
  // Ground mode, box robots: the second try, the box at its heading where its turning cylinder
  // does not fit (null otherwise).
  std::unique_ptr<RobotValidity> headed;
  RoadwayGraph graph;
  bool from_survey = false;

  Impl(const map::OccupancyMap& m, const map::DistanceField& f, map::CollisionChecker c, const GlobalPlannerParams& p)
      : map(&m), field(&f), checker(std::move(c)), params(p) {
    validity = std::make_unique<RobotValidity>(*field, checker, params);
    if (params.mode == PlanMode::kGround && params.robot.type == map::ShapeType::kBox)
      headed = std::make_unique<RobotValidity>(*field, checker, params, true);
  }

  // Ground mode: a survey roadway's cross-section is passable when the robot can stand somewhere
  // on its floor (a gap above a roof fall's rubble is not a way for a ground robot). Empty (the
  // default clearance test) when flying.
  RoadwayGraph::SectionTest sectionTest() const {
    if (!validity->ground()) return {};
    const RobotValidity* v = validity.get();
    const map::DistanceField* f = field;
    return [v, f](const Vec3& c, const Vec3& t, double radius) {
      const double res = f->resolution();
      Vec3 side(-t.y(), t.x(), 0.0);
      side = side.norm() > 1e-6 ? Vec3(side.normalized()) : Vec3(Vec3::UnitY());
      for (double u = 0.0; u <= radius; u += res)
        for (const double sgn : {1.0, -1.0}) {
          if (u == 0.0 && sgn < 0.0) continue;
          const Vec3 p = c + sgn * u * side;
          // From high in the section down to its floor: the first free start above the floor.
          for (const double h : {0.9, 0.5, 0.0, -0.5}) {
            const Vec3 top = p + Vec3(0, 0, h * radius);
            if (!f->isFree(top)) continue;
            const std::optional<Vec3> stand = v->onFloor(top, 2.0 * radius + 1.0);
            if (stand && v->stateValid(*stand)) return true;
            break;
          }
        }
      return false;
    };
  }

  // Outcome for an unusable endpoint, or nullopt when it is fine; `p` is snapped in ground mode.
  std::optional<GlobalPlanResult> checkEndpoint(const RobotValidity& vr, Vec3* p, bool is_start) const {
    GlobalPlanResult r;
    const char* what = is_start ? "start" : "goal";
    auto fail = [&](GlobalPlanOutcome start_o, GlobalPlanOutcome goal_o, const std::string& why) {
      r.outcome = is_start ? start_o : goal_o;
      r.message = std::string(what) + " " + fmt(*p) + ": " + why;
      return r;
    };
    if (!map::allFinite(*p)) return fail(GlobalPlanOutcome::kStartOutsideMap, GlobalPlanOutcome::kGoalOutsideMap, "coordinates are not finite");
    if (!map->bounds().contains(*p))
      return fail(GlobalPlanOutcome::kStartOutsideMap, GlobalPlanOutcome::kGoalOutsideMap, "outside the map's bounds " +
                  fmt(map->bounds().min) + " - " + fmt(map->bounds().max));
    // The field was built from the map under its policy and says the same of every voxel; asking
    // it first leaves a map read from the cache without its octree unless the point is rock.
    if (!field->isFree(*p)) {
      if (map->state(*p) == map::VoxelState::kUnknown)
        return fail(GlobalPlanOutcome::kStartUnknown, GlobalPlanOutcome::kGoalUnknown, "in unknown space (rock under --unknown rock)");
      return fail(GlobalPlanOutcome::kStartInRock, GlobalPlanOutcome::kGoalInRock, "in rock");
    }
    if (vr.ground()) {
      const std::optional<Vec3> q = vr.onFloor(*p, 50.0);
      if (!q) return fail(GlobalPlanOutcome::kStartInRock, GlobalPlanOutcome::kGoalInRock, "no floor under it");
      *p = *q;
    }
    if (!vr.stateValid(*p)) {
      std::ostringstream m;
      m.precision(2);
      m << std::fixed << "the robot (" << params.robot.name() << ") does not fit";
      if (vr.headed()) m << " at any heading";
      m << ": clearance " << vr.clearance(*p) << " m" << (vr.headed() ? " turning" : "") << ", needs "
        << params.safety_margin_m << " m";
      return fail(GlobalPlanOutcome::kStartInRock, GlobalPlanOutcome::kGoalInRock, m.str());
    }
    return std::nullopt;
  }

  GlobalPlanResult plan(Vec3 start, Vec3 goal) const;
  GlobalPlanResult planWith(const RobotValidity& vr, Vec3 start, Vec3 goal) const;
};

GlobalPlanner::GlobalPlanner(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GlobalPlanner::GlobalPlanner(GlobalPlanner&&) noexcept = default;
GlobalPlanner& GlobalPlanner::operator=(GlobalPlanner&&) noexcept = default;
GlobalPlanner::~GlobalPlanner() = default;

StatusOr<GlobalPlanner> GlobalPlanner::create(const map::OccupancyMap& map, const map::DistanceField& field,
                                              const GlobalPlannerParams& params, const map::SurveyNetwork* survey) {
  ADIT_RETURN_IF_ERROR(params.validate());
  ADIT_ASSIGN_OR_RETURN(map::CollisionChecker checker, map::CollisionChecker::create(map, field));
  auto impl = std::make_unique<Impl>(map, field, std::move(checker), params);
  if (params.use_roadway_graph) {
    if (survey) {
      ADIT_ASSIGN_OR_RETURN(impl->graph, RoadwayGraph::fromSurvey(*survey));
      impl->from_survey = true;
    } else {
      FreeSpaceGraphOptions options;
      options.slice_m = params.skeleton_cell_m;
      options.max_memory_bytes = params.max_graph_memory_bytes;
      ADIT_ASSIGN_OR_RETURN(impl->graph, RoadwayGraph::fromFreeSpace(map, field,
                                                                     impl->validity->requiredClearance(), options));
    }
    // A free-space graph is built on this field: every passage is open by construction.
    if (impl->from_survey)
      impl->graph.refreshBlocked(field, impl->validity->requiredClearance(), map::Aabb(), impl->sectionTest());
  }
  // Libraries do not print: OMPL's console output is off.
  ompl::msg::noOutputHandler();
  return GlobalPlanner(std::move(impl));
}

GlobalPlanResult GlobalPlanner::plan(const Vec3& start, const Vec3& goal) const { return impl_->plan(start, goal); }

// A ground box robot is planned first as its turning cylinder (a path it may turn on anywhere,
// which leaves the local planner room); where that finds none, with the box at its heading.
GlobalPlanResult GlobalPlanner::Impl::plan(Vec3 start, Vec3 goal) const {
  GlobalPlanResult first = planWith(*validity, start, goal);
  if (first.solved() || !headed) return first;
  switch (first.outcome) {
    case GlobalPlanOutcome::kStartUnknown:
    case GlobalPlanOutcome::kGoalUnknown:
    case GlobalPlanOutcome::kStartOutsideMap:
    case GlobalPlanOutcome::kGoalOutsideMap:
    case GlobalPlanOutcome::kError: return first;
    default: break;
  }
  GlobalPlanResult second = planWith(*headed, start, goal);
  const double spent = first.planning_time_s + second.planning_time_s;
  if (!second.solved()) {
    first.message += "; with the box at its heading: " + second.message;
    first.planning_time_s = spent;
    return first;
  }
  second.headed = true;
  second.planning_time_s = spent;
  second.message += "; its turning circle does not fit everywhere: the box is checked at the path's heading";
  return second;
}

GlobalPlanResult GlobalPlanner::Impl::planWith(const RobotValidity& vr, Vec3 start, Vec3 goal) const {
  const Clock::time_point t0 = Clock::now();
  auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
  GlobalPlanResult result;
  result.planner = plannerTypeName(params.planner);
  auto finish = [&](GlobalPlanResult r) {
    r.planner = plannerTypeName(params.planner);
    r.planning_time_s = seconds(t0, Clock::now());
    return r;
  };
  if (std::optional<GlobalPlanResult> bad = checkEndpoint(vr, &start, true)) return finish(*bad);
  if (std::optional<GlobalPlanResult> bad = checkEndpoint(vr, &goal, false)) return finish(*bad);

  // Route on the roadway graph; the corridor is where OMPL may go.
  std::unique_ptr<Corridor> corridor;
  std::vector<Vec3> route_axis;  // start, the route's axis, goal: a path whenever it is valid
  const double res = field->resolution();
  if (params.use_roadway_graph) {
    EdgeFilter climbable;
    if (vr.ground() && from_survey) {
      const double limit = params.max_slope_deg;
      climbable = [limit](const RoadwayEdge& e) { return e.max_slope_deg <= limit; };
    }
    StatusOr<Route> route = graph.route(start, goal, climbable);
    if (!route.ok()) {
      result.outcome = GlobalPlanOutcome::kNoPath;
      result.message = "no path: " + route.status().message();
      if (climbable) {
        // Say so when only the slope limit stands in the way.
        StatusOr<Route> any = graph.route(start, goal);
        if (any.ok()) {
          const RoadwayEdge* steepest = nullptr;
          for (int e : any->edges)
            if (!steepest || graph.edges()[std::size_t(e)].max_slope_deg > steepest->max_slope_deg)
              steepest = &graph.edges()[std::size_t(e)];
          std::ostringstream m;
          m.precision(1);
          m << std::fixed << "no path for a ground robot: roadway " << steepest->roadway << " is too steep ("
            << steepest->max_slope_deg << " deg > max slope " << params.max_slope_deg << " deg)";
          result.message = m.str();
        }
      }
      return finish(result);
    }
    result.route = route->roadways;
    result.route_edges = route->edges;
    route_axis = route->axis.points;
    corridor = std::make_unique<Corridor>(*route, from_survey ? res : 0.5 * params.skeleton_cell_m);
  } else {
    corridor = std::make_unique<Corridor>(map->bounds());
  }

  try {
    // Every OMPL random number generator created from here on draws its seed from this one.
    ompl::RNG::setSeed(params.seed == 0 ? 0x9E3779B9u : params.seed);
    auto space = std::make_shared<ob::RealVectorStateSpace>(3);
    map::Aabb box = corridor->bounds();
    box.min = box.min.cwiseMax(map->bounds().min);
    box.max = box.max.cwiseMin(map->bounds().max);
    ob::RealVectorBounds bounds(3);
    for (int i = 0; i < 3; ++i) {
      bounds.setLow(i, box.min[i]);
      bounds.setHigh(i, std::max(box.max[i], box.min[i] + res));
    }
    space->setBounds(bounds);
    std::uint64_t sampler_seed = params.seed;
    const Corridor& corr = *corridor;
    const RobotValidity& val = vr;
    // The plain-OMPL baseline (whole box, flying) keeps OMPL's own uniform sampler.
    const bool plain = corr.isBox() && !val.ground();
    if (!plain)
      space->setStateSamplerAllocator([&corr, &val, &sampler_seed](const ob::StateSpace* s) {
        return std::make_shared<CorridorSampler>(s, corr, val, 0x5DEECE66Dull * ++sampler_seed);
      });
    auto si = std::make_shared<ob::SpaceInformation>(space);
    si->setStateValidityChecker([&corr, &val](const ob::State* s) {
      const Vec3 p = toVec(s);
      return corr.contains(p) && val.stateValid(p);
    });
    si->setMotionValidator(std::make_shared<MotionCheck>(si, val));
    si->setup();

    auto pdef = std::make_shared<ob::ProblemDefinition>(si);
    ob::ScopedState<> s(space), g(space);
    fromVec(start, s.get());
    fromVec(goal, g.get());
    pdef->setStartAndGoalStates(s, g, 1e-9);
    pdef->setOptimizationObjective(std::make_shared<ClearanceObjective>(si, val));
    std::atomic<bool> have_solution{false};
    double first_time = -1;
    const Clock::time_point ompl_start = Clock::now();
    pdef->setIntermediateSolutionCallback([&](const ob::Planner*, const std::vector<const ob::State*>&, const ob::Cost) {
      if (!have_solution.exchange(true)) first_time = seconds(t0, Clock::now());
    });

    // A search may find nothing in a long corridor (a whole mine, thousands of metres) though a
    // path exists: the route's own axis is one whenever it is valid. Shortened with the same
    // re-validated steps as a search's path, it is the first solution, and the answer when the
    // search finds none or a longer one.
    std::vector<Vec3> axis_path;
    double axis_time = 0.0;
    if (route_axis.size() >= 2 && validatePoints(val, route_axis).ok()) {
      axis_path = polish(val, route_axis);
      axis_time = seconds(t0, Clock::now());
    }

    ob::PlannerPtr planner;
    // Range: OMPL's default (a fifth of the bounds' extent). Measured on the district, shorter
    // steps (6 m, 20 m) made RRT* miss the 2 s budget more often; roadways are long and straight.
    switch (params.planner) {
      case PlannerType::kRrtConnect: planner = std::make_shared<og::RRTConnect>(si); break;
      case PlannerType::kRrtStar: planner = std::make_shared<og::RRTstar>(si); break;
      case PlannerType::kInformedRrtStar: planner = std::make_shared<og::InformedRRTstar>(si); break;
      case PlannerType::kBitStar: planner = std::make_shared<og::BITstar>(si); break;
      case PlannerType::kPrmStar: planner = std::make_shared<og::PRMstar>(si); break;
    }
    planner->setProblemDefinition(pdef);
    planner->setup();

    const bool anytime = isAnytime(params.planner);
    const Clock::time_point deadline =
        ompl_start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(params.time_budget_s));
    std::atomic<long> iterations{0};
    std::atomic<bool> timed_out{false};
    std::atomic<bool> iteration_capped{false};
    const bool prm = params.planner == PlannerType::kPrmStar;
    ob::PlannerTerminationCondition ptc([&] {
      if (Clock::now() >= deadline) {
        timed_out = true;
        return true;
      }
      const long it = ++iterations;
      const bool solved = have_solution || pdef->hasExactSolution();
      if (params.max_unsolved_iterations > 0 && !solved && it >= params.max_unsolved_iterations) {
        iteration_capped = true;
        return true;
      }
      if (!anytime) return false;
      return it >= params.max_iterations && (solved || prm);
    });
    const ob::PlannerStatus status = planner->solve(ptc);
    result.ompl_time_s = seconds(ompl_start, Clock::now());
    result.time_limited = timed_out;
    result.iterations = iterations;
    const bool exact = status == ob::PlannerStatus::EXACT_SOLUTION;
    if (!exact && !axis_path.empty()) {
      result.first_solution_time_s = axis_time;
      result.from_route_axis = true;
      result.path.points = axis_path;
    } else if (!exact && status != ob::PlannerStatus::APPROXIMATE_SOLUTION) {
      result.outcome = GlobalPlanOutcome::kTimeout;
      std::ostringstream m;
      if (iteration_capped)
        m << "no path found by " << result.planner << " in " << params.max_unsolved_iterations << " iterations";
      else
        m << "no path found by " << result.planner << " within " << params.time_budget_s << " s"
          << (anytime ? " / " + std::to_string(params.max_iterations) + " iterations" : std::string());
      if (!result.route.empty()) m << " in the corridor of the route through " << result.route.size() << " roadways";
      result.message = m.str();
      return finish(result);
    } else {
      result.first_solution_time_s = first_time >= 0 ? first_time : seconds(t0, Clock::now());
      auto path = pdef->getSolutionPath()->as<og::PathGeometric>();
      og::PathGeometric work(*path);
      result.ompl_vertices = work.getStateCount();
      auto points = [](const og::PathGeometric& p) {
        std::vector<Vec3> v;
        for (std::size_t i = 0; i < p.getStateCount(); ++i) v.push_back(toVec(p.getState(i)));
        return v;
      };
      std::vector<Vec3> best = points(work);
      if (!exact) {
        result.outcome = GlobalPlanOutcome::kApproximateSolution;
        result.path.points = best;
        result.length_m = result.path.length();
        result.message = "only an approximate path (ending " + fmt(best.back()) + ", " +
                         std::to_string((best.back() - goal).norm()) + " m short of the goal) " +
                         (iteration_capped ? "in " + std::to_string(params.max_unsolved_iterations) + " iterations"
                                           : std::string("within the budget"));
        return finish(result);
      }
      // Segments only: a headed box's turns at the raw path's many break points are the
      // simplification's to mend (checked below).
      Status raw_ok = validatePoints(val, best, false);
      if (!raw_ok.ok()) {
        // OMPL checks motions one at a time; a chain of short ones can still climb too steeply.
        result.outcome = val.pathSlopeValid(best) ? GlobalPlanOutcome::kError : GlobalPlanOutcome::kNoPath;
        result.message = "OMPL returned an invalid path: " + raw_ok.message();
        return finish(result);
      }
      // OMPL's simplifier first, kept only when every segment re-validates, then adit's own.
      og::PathSimplifier simplifier(si, pdef->getGoal(), pdef->getOptimizationObjective());
      simplifier.reduceVertices(work);
      simplifier.shortcutPath(work);
      const std::vector<Vec3> simplified = points(work);
      if (simplified.size() >= 2 && simplified.front() == best.front() && simplified.back() == best.back() &&
          validatePoints(val, simplified, false).ok() && val.badTurns(simplified) <= val.badTurns(best))
        best = simplified;
      best = polish(val, best);
      std::size_t turn_at = 0;
      if (val.badTurns(best, &turn_at) > 0) {
        if (axis_path.empty()) {
          result.outcome = GlobalPlanOutcome::kNoPath;
          result.message = "no path: the robot's box (" + params.robot.name() + ") cannot turn at " + fmt(best[turn_at]) +
                           " from the heading it comes in at to the one it leaves at, on the path found";
          return finish(result);
        }
        best = axis_path;  // valid, turns included
        result.from_route_axis = true;
      }
      result.path.points = best;
      if (!axis_path.empty() && map::Polyline{axis_path}.length() < map::Polyline{best}.length() - 1e-9) {
        result.path.points = axis_path;
        result.from_route_axis = true;
      }
      if (!axis_path.empty()) result.first_solution_time_s = std::min(result.first_solution_time_s, axis_time);
    }
  } catch (const std::exception& e) {
    result.outcome = GlobalPlanOutcome::kError;
    result.message = std::string("OMPL failed: ") + e.what();
    result.path.points.clear();
    return finish(result);
  }

  if (vr.ground()) {
    // Every break point exactly half the robot's height above its floor. A state within the
    // ground tolerance is valid (its body is checked standing on the floor), but the local layer
    // steers at the point itself, and one left below the floor's top lies in rock.
    std::vector<Vec3> on = result.path.points;
    bool all = true;
    for (Vec3& p : on) {
      const std::optional<Vec3> q = snap(vr, p, 0.3);
      all = all && q.has_value();
      if (q) p = *q;
    }
    if (all && validatePoints(vr, on).ok()) result.path.points = std::move(on);
  }
  result.outcome = GlobalPlanOutcome::kExactSolution;
  result.length_m = result.path.length();
  // Clearance along the path, a sample per voxel.
  double sum = 0, lowest = std::numeric_limits<double>::infinity();
  std::size_t count = 0;
  const std::vector<Vec3>& p = result.path.points;
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    const int n = std::max(1, int(std::ceil((p[i + 1] - p[i]).norm() / res)));
    const double yaw = std::atan2(p[i + 1].y() - p[i].y(), p[i + 1].x() - p[i].x());
    for (int k = 0; k < n + (i + 2 == p.size() ? 1 : 0); ++k) {
      const double c = vr.clearance(p[i] + (p[i + 1] - p[i]) * (double(k) / n), yaw);
      sum += c;
      lowest = std::min(lowest, c);
      ++count;
    }
  }
  result.min_clearance_m = count ? lowest : 0.0;
  result.mean_clearance_m = count ? sum / double(count) : 0.0;
  std::ostringstream m;
  m.precision(1);
  const std::size_t breaks = p.size() >= 2 ? p.size() - 2 : 0;
  m << std::fixed << "path of " << result.length_m << " m with " << breaks << " break point" << (breaks == 1 ? "" : "s");
  if (!result.route.empty()) m << " through " << result.route.size() << " roadway" << (result.route.size() > 1 ? "s" : "");
  if (result.from_route_axis)
    m << "; the route's axis, shortened (" << result.planner << " found "
      << (result.ompl_vertices ? "a longer one" : "none within the budget") << ")";
  else if (result.time_limited) m << "; the time budget cut the search short (result depends on timing)";
  result.message = m.str();
  return finish(result);
}

int GlobalPlanner::mapChanged(const map::Aabb& changed) {
  return impl_->graph.refreshBlocked(*impl_->field, impl_->validity->requiredClearance(), changed,
                                     impl_->sectionTest());
}

Status GlobalPlanner::validatePath(const Polyline& path) const {
  // A box's path is valid when it is at its headings (which a path its turning cylinder keeps
  // to always is); the reason given is the headed check's.
  if (impl_->headed) return validatePoints(*impl_->headed, path.points);
  return validatePoints(*impl_->validity, path.points);
}

bool GlobalPlanner::stateValid(const Vec3& c) const { return impl_->validity->stateValid(c); }

std::optional<Vec3> GlobalPlanner::standAt(const Vec3& c) const {
  if (!map::allFinite(c)) return std::nullopt;
  return snap(*impl_->validity, c, 0.5);
}

std::optional<Vec3> GlobalPlanner::backOff(const Vec3& c, double max_move_m) const {
  const RobotValidity& v = *impl_->validity;
  const map::DistanceField& f = *impl_->field;
  if (!map::allFinite(c) || !(max_move_m >= 0.0) || !f.isFree(c)) return std::nullopt;
  Vec3 q = c;
  if (v.ground()) {
    const std::optional<Vec3> on = v.onFloor(q, 2.0 * v.halfHeight() + max_move_m);
    if (!on) return std::nullopt;
    q = *on;
  }
  // Up the gradient the clearance grows by about a step per step until the nearest rock changes;
  // a ridge between two ribs (both too close) stops it, and the pose is then refused. A ground
  // robot reads the field where its body's clearance is read (lifted off the floor, which is
  // otherwise the nearest rock and sends the gradient straight up) and backs off along the floor.
  const Vec3 up(0, 0, v.lift());
  const double step = 0.5 * f.resolution(), start_distance = f.distance(q + up);
  for (double moved = (q - c).norm(); moved <= max_move_m + 1e-9; moved += step) {
    if (v.stateValid(q)) return q;
    const map::DistanceSample s = f.query(q + up);
    Vec3 g = s.gradient;
    if (v.ground()) g.z() = 0.0;
    if (s.in_rock || g.squaredNorm() < 0.25) return std::nullopt;
    Vec3 next = q + step * g.normalized();
    if (v.ground()) {
      const std::optional<Vec3> on = v.onFloor(next + Vec3(0, 0, step), 2.0 * step + v.halfHeight());
      if (!on) return std::nullopt;
      next = *on;
    }
    if (f.distance(next + up) + 1e-9 < start_distance) return std::nullopt;  // never closer to rock than it stood
    q = next;
  }
  return std::nullopt;
}

const RoadwayGraph& GlobalPlanner::graph() const { return impl_->graph; }
RoadwayGraph& GlobalPlanner::graph() { return impl_->graph; }
const GlobalPlannerParams& GlobalPlanner::params() const { return impl_->params; }
double GlobalPlanner::requiredClearance() const { return impl_->validity->requiredClearance(); }

}  // namespace adit::global
