// SPDX-License-Identifier: BSD-3-Clause
// Map-layer benchmarks. Run: build/tests/bench/adit_map_bench [--benchmark_filter=...]
// Speed is reported as ratios against a baseline measured in the same run (the machines are
// shared and noisy): the summary at the end prints them.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <random>

#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/survey_network.hpp"
#include "support/synthetic_roadway.hpp"

namespace {

using namespace adit;
using namespace adit::map;

struct World {
  SurveyNetwork net;
  OccupancyMap map;
  DistanceField field;
  std::vector<Vec3> random_free;  // uniformly random free points
  std::vector<Vec3> path;         // 5 cm steps along every centreline, 1.2 m above the floor
};

World makeWorld(SurveyNetwork net) {
  StatusOr<OccupancyMap> map = voxelize(net);
  if (!map.ok()) { std::fprintf(stderr, "%s\n", map.status().toString().c_str()); std::abort(); }
  StatusOr<DistanceField> df = DistanceField::build(*map);
  if (!df.ok()) { std::fprintf(stderr, "%s\n", df.status().toString().c_str()); std::abort(); }
  World w{std::move(net), std::move(map).value(), std::move(df).value(), {}, {}};
  std::mt19937_64 rng(1);
  const Aabb b = w.map.bounds();
  while (w.random_free.size() < (1u << 16)) {
    const Vec3 p = adit::test::randomPoint(rng, b);
    if (w.field.isFree(p)) w.random_free.push_back(p);
  }
  for (const SurveyRoadway& r : w.net.roadways) {
    const Polyline line = w.net.centreline(r);
    for (std::size_t i = 1; i < line.size(); ++i) {
      const Vec3 d = line.points[i] - line.points[i - 1];
      for (double t = 0; t < d.norm(); t += 0.05) w.path.push_back(line.points[i - 1] + d.normalized() * t + Vec3(0, 0, 1.2));
    }
  }
  return w;
}

World& district() {
  static World w = [] {
    StatusOr<SurveyNetwork> net = loadSurvey(std::string(ADIT_MAPS_DIR) + "/district.yaml");
    if (!net.ok()) std::abort();
    return makeWorld(*net);
  }();
  return w;
}

void BM_DistanceField_RandomPoints(benchmark::State& state) {
  World& w = district();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(w.field.query(w.random_free[i++ & 0xFFFF]));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DistanceField_RandomPoints);

void BM_DistanceField_AlongPath(benchmark::State& state) {
  World& w = district();
  std::size_t i = 0;
  const std::size_t n = w.path.size();
  for (auto _ : state) {
    benchmark::DoNotOptimize(w.field.query(w.path[i]));
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DistanceField_AlongPath);

// What a robot's local planner does: re-query a 20 m stretch of roadway (1 cm steps) every
// cycle, so the tiles around the robot stay in cache. The full-district walk above streams
// 114 MB of tiles instead.
void BM_DistanceField_AlongPathWarm(benchmark::State& state) {
  World& w = district();
  std::vector<Vec3> stretch;
  for (double x = 100.0; x < 120.0; x += 0.01) stretch.push_back(Vec3(x, 0.5, -3.0));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(w.field.query(stretch[i]));
    if (++i == stretch.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DistanceField_AlongPathWarm);

// The baseline: FCL's octree distance for a sphere (radius 0.3 m) at the same random points.
void BM_FclOctree_SphereDistance(benchmark::State& state) {
  World& w = district();
  static StatusOr<FclOctreeDistance> fcl = FclOctreeDistance::create(w.map);
  const RobotShape sphere = RobotShape::sphere(0.3);
  std::size_t i = 0;
  for (auto _ : state) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = w.random_free[(i++ * 97) & 0xFFFF];
    benchmark::DoNotOptimize(fcl->distance(sphere, pose));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_FclOctree_SphereDistance)->Unit(benchmark::kMicrosecond);

// The same sphere query through the distance field (what planners use instead).
void BM_CollisionChecker_SphereDistance(benchmark::State& state) {
  World& w = district();
  static StatusOr<CollisionChecker> checker = CollisionChecker::create(w.map, w.field);
  const RobotShape sphere = RobotShape::sphere(0.3);
  std::size_t i = 0;
  for (auto _ : state) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = w.random_free[(i++ * 97) & 0xFFFF];
    benchmark::DoNotOptimize(checker->distance(sphere, pose));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CollisionChecker_SphereDistance)->Unit(benchmark::kMicrosecond);

// A capsule robot (r 0.4 m, 1.2 m long) 0.15-0.5 m from the main roadway's wall, exact distance
// within 1 m: the FCL narrow phase on the voxels near the robot.
void BM_CollisionChecker_CapsuleNearWall(benchmark::State& state) {
  World& w = district();
  static StatusOr<CollisionChecker> checker = CollisionChecker::create(w.map, w.field);
  const RobotShape capsule = RobotShape::capsule(0.4, 1.2);
  std::vector<Eigen::Isometry3d> poses;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  while (poses.size() < 256) {
    const Vec3 p = w.path[std::size_t(u(rng) * double(w.path.size() - 1))];
    const DistanceSample s = w.field.query(p);
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix() *
                    Eigen::AngleAxisd(u(rng) * M_PI, Vec3::UnitX()).toRotationMatrix();
    // Slide from the centreline towards the nearest wall until 0.15-0.5 m from it.
    pose.translation() = s.nearest + s.gradient * (0.4 + 0.15 + 0.35 * u(rng));
    if (!checker->inCollision(capsule, pose)) poses.push_back(pose);
  }
  std::size_t i = 0;
  std::int64_t fcl_calls = 0;
  for (auto _ : state) {
    const ShapeDistance d = checker->distance(capsule, poses[i++ & 255], 1.0);
    fcl_calls += d.candidates_checked;
    benchmark::DoNotOptimize(d);
  }
  state.counters["fcl_calls_per_query"] = double(fcl_calls) / double(state.iterations());
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CollisionChecker_CapsuleNearWall)->Unit(benchmark::kMicrosecond);

void reportBuild(benchmark::State& state, const DistanceFieldStats& s) {
  state.counters["free_voxels"] = double(s.free_voxels);
  const double n = double(state.iterations());
  state.counters["tile_voxels_per_s"] = benchmark::Counter(n * double(s.blocks) * 4096.0, benchmark::Counter::kIsRate);
  state.counters["free_voxels_per_s"] = benchmark::Counter(n * double(s.free_voxels), benchmark::Counter::kIsRate);
  state.counters["bytes_per_free_voxel"] = s.bytesPerFreeVoxel();
  state.counters["MiB"] = double(s.memory_bytes) / (1 << 20);
  // The Euclidean transform alone, without reading the octree (pointer chasing in OctoMap).
  state.counters["transform_voxels_per_s"] = s.transformVoxelsPerSecond();
}

void BM_DistanceField_Build_District(benchmark::State& state) {
  World& w = district();
  DistanceFieldStats stats;
  for (auto _ : state) {
    StatusOr<DistanceField> df = DistanceField::build(w.map);
    stats = df->stats();
    benchmark::DoNotOptimize(df);
  }
  reportBuild(state, stats);
}
BENCHMARK(BM_DistanceField_Build_District)->Unit(benchmark::kMillisecond)->Iterations(5);

// 2 km x 1 km district, 13 km of roadway at 0.2 m: voxelized once (slow, not timed).
void BM_DistanceField_Build_Synthetic2kmx1km(benchmark::State& state) {
  static OccupancyMap map = [] {
    StatusOr<OccupancyMap> m = voxelize(adit::test::syntheticDistrict(2000, 1000, 0.2));
    if (!m.ok()) std::abort();
    return std::move(m).value();
  }();
  DistanceFieldStats stats;
  for (auto _ : state) {
    StatusOr<DistanceField> df = DistanceField::build(map);
    stats = df->stats();
    benchmark::DoNotOptimize(df);
  }
  reportBuild(state, stats);
  const double box_voxels = map.bounds().volume() / std::pow(map.resolution(), 3);
  state.counters["bbox_dense_GiB"] = box_voxels * 8.0 / double(1u << 30);
}
BENCHMARK(BM_DistanceField_Build_Synthetic2kmx1km)->Unit(benchmark::kMillisecond)->Iterations(2);

// Windowed rebuild after 1 m^3 of rubble falls into the main roadway.
void BM_DistanceField_UpdateWindow(benchmark::State& state) {
  World& w = district();
  OccupancyMap map = w.map;
  StatusOr<DistanceField> df = DistanceField::build(map);
  std::vector<Vec3> rubble;
  for (double x = 100; x < 101; x += 0.2)
    for (double y = -0.5; y < 0.5; y += 0.2)
      for (double z = -4.0; z < -3.0; z += 0.2) rubble.push_back({x, y, z});
  const Aabb window({100, -0.5, -4.0}, {101, 0.5, -3.0});
  bool occupied = true;
  for (auto _ : state) {
    state.PauseTiming();
    (void)map.setVoxels(rubble, occupied ? VoxelState::kOccupied : VoxelState::kFree);
    occupied = !occupied;
    state.ResumeTiming();
    benchmark::DoNotOptimize(df->update(map, window));
  }
}
BENCHMARK(BM_DistanceField_UpdateWindow)->Unit(benchmark::kMillisecond);

// Collects per-iteration times so that ratios measured in this run can be printed at the end.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& r : runs)
      if (r.run_type == Run::RT_Iteration && r.iterations > 0)
        ns_[r.benchmark_name()] = r.GetAdjustedRealTime() * multiplier(r.time_unit);
    ConsoleReporter::ReportRuns(runs);
  }
  void printRatios() const {
    auto ratio = [&](const char* slow, const char* fast, const char* what) {
      auto a = ns_.find(slow), b = ns_.find(fast);
      if (a == ns_.end() || b == ns_.end()) return;
      std::printf("  %-62s %10.0fx  (%.1f ns vs %.1f ns)\n", what, a->second / b->second, b->second, a->second);
    };
    std::printf("\nRatios measured in this run (baseline / adit):\n");
    ratio("BM_FclOctree_SphereDistance", "BM_DistanceField_RandomPoints",
          "fcl::OcTree sphere distance / distance-field lookup (random)");
    ratio("BM_FclOctree_SphereDistance", "BM_DistanceField_AlongPath",
          "fcl::OcTree sphere distance / distance-field lookup (path)");
    ratio("BM_FclOctree_SphereDistance", "BM_DistanceField_AlongPathWarm",
          "fcl::OcTree sphere distance / distance-field lookup (path, warm)");
    ratio("BM_FclOctree_SphereDistance", "BM_CollisionChecker_SphereDistance",
          "fcl::OcTree sphere distance / CollisionChecker sphere distance");
  }

 private:
  static double multiplier(benchmark::TimeUnit u) {
    switch (u) {
      case benchmark::kNanosecond: return 1.0;
      case benchmark::kMicrosecond: return 1e3;
      case benchmark::kMillisecond: return 1e6;
      case benchmark::kSecond: return 1e9;
    }
    return 1.0;
  }
  std::map<std::string, double> ns_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.printRatios();
  benchmark::Shutdown();
  return 0;
}
