// SPDX-License-Identifier: BSD-3-Clause
// Global-planner benchmarks on whole districts, between the two farthest roadway ends: the
// bundled district and a synthetic 2 km x 1 km district (13 km of roadway). Each case runs
// beside the baseline, plain OMPL sampling the map's whole bounding box with the same validity
// checker ("BBox" rows). Run: build/tests/bench/adit_global_bench [--benchmark_filter=...]
// Counters: first_ms (until OMPL's first raw path), length_m, solved (fraction of iterations).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>

#include "adit/global/global_planner.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "support/synthetic_roadway.hpp"

namespace {

using namespace adit;
using namespace adit::map;

struct World {
  SurveyNetwork net;
  OccupancyMap map;
  DistanceField field;
};

template <class T>
T orDie(StatusOr<T> v) {
  if (!v.ok()) {
    std::fprintf(stderr, "%s\n", v.status().toString().c_str());
    std::abort();
  }
  return std::move(v).value();
}

const World& district() {
  static const std::unique_ptr<World> w = [] {
    LoadedMap l = orDie(loadMapAndSurvey(ADIT_MAPS_DIR "/district.yaml"));
    DistanceField f = orDie(DistanceField::build(l.map));
    return std::make_unique<World>(World{std::move(*l.survey), std::move(l.map), std::move(f)});
  }();
  return *w;
}

const World& synthetic() {
  static const std::unique_ptr<World> w = [] {
    SurveyNetwork net = adit::test::syntheticDistrict(2000, 1000, 0.2);
    OccupancyMap m = orDie(voxelize(net));
    DistanceField f = orDie(DistanceField::build(m));
    return std::make_unique<World>(World{std::move(net), std::move(m), std::move(f)});
  }();
  return *w;
}

void planFarthest(benchmark::State& state, const World& w, global::PlannerType type, bool baseline) {
  global::GlobalPlannerParams p;
  p.planner = type;
  p.use_roadway_graph = !baseline;
  global::GlobalPlanner reference = orDie(global::GlobalPlanner::create(w.map, w.field, {}, &w.net));
  const auto ends = reference.graph().farthestEnds();
  const double inset = 2.0 + reference.requiredClearance();
  const Vec3 a = reference.graph().pointNearEnd(ends->first, inset), b = reference.graph().pointNearEnd(ends->second, inset);
  global::GlobalPlanner planner = orDie(global::GlobalPlanner::create(w.map, w.field, p, &w.net));
  double first = 0, length = 0, solved = 0;
  for (auto _ : state) {
    const global::GlobalPlanResult r = planner.plan(a, b);
    first += r.first_solution_time_s;
    length += r.length_m;
    solved += r.solved();
  }
  const double n = double(state.iterations());
  state.counters["first_ms"] = 1e3 * first / n;
  state.counters["length_m"] = length / n;
  state.counters["solved"] = solved / n;
}

#define ADIT_GLOBAL_BENCH(world, planner, type)                                                              \
  void BM_##world##_##planner(benchmark::State& s) { planFarthest(s, world(), global::PlannerType::type, false); } \
  void BM_##world##_##planner##_BBox(benchmark::State& s) { planFarthest(s, world(), global::PlannerType::type, true); } \
  BENCHMARK(BM_##world##_##planner)->Unit(benchmark::kMillisecond)->Iterations(3);                          \
  BENCHMARK(BM_##world##_##planner##_BBox)->Unit(benchmark::kMillisecond)->Iterations(3)

ADIT_GLOBAL_BENCH(district, RRTConnect, kRrtConnect);
ADIT_GLOBAL_BENCH(district, BITstar, kBitStar);
ADIT_GLOBAL_BENCH(synthetic, RRTConnect, kRrtConnect);
ADIT_GLOBAL_BENCH(synthetic, BITstar, kBitStar);

}  // namespace

BENCHMARK_MAIN();
