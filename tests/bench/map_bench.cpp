// SPDX-License-Identifier: BSD-3-Clause
// Map-layer benchmarks. Run: build/tests/bench/adit_map_bench [--benchmark_filter=...]
// Speed is reported as ratios against a baseline measured in the same run (the machines are
// shared and noisy): the summary at the end prints them.
#include <benchmark/benchmark.h>
#include <octomap/OcTree.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <unordered_map>

#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"
#include "adit/map/rock_points.hpp"
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

// The layout the field had before issue 19: 16^3 tiles of 8-byte words (the nearest rock
// voxel's key, 16 bits per axis, plus free and site flags) under a dense tile index, 25 bytes per
// free voxel on the district. Rebuilt here from the field's own answers (the nearest rock voxel
// of every free voxel) so that both layouts are timed in one run on the same data; its query is
// the one the field had.
class WideField {
 public:
  WideField(const OccupancyMap& map, const DistanceField& field) : res_(map.resolution()), inv_(1.0 / res_) {
    const octomap::OcTree& tree = map.octree();
    std::unordered_map<std::uint64_t, std::uint32_t> tile_of;
    std::vector<std::array<int, 3>> coords;
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      if (tree.isNodeOccupied(*it)) continue;
      const int size = 1 << (tree.getTreeDepth() - it.getDepth());
      const octomap::OcTreeKey k0 = it.getIndexKey();
      for (int z = k0[2]; z < k0[2] + size; ++z)
        for (int y = k0[1]; y < k0[1] + size; ++y)
          for (int x = k0[0]; x < k0[0] + size; ++x) {
            const Vec3 c = centre(x, y, z);
            if (!field.isFree(c)) continue;
            const Vec3 s = field.nearestRockVoxel(c);
            const std::uint64_t key = (std::uint64_t(x >> 4) << 42) | (std::uint64_t(y >> 4) << 21) | std::uint64_t(z >> 4);
            auto [t, inserted] = tile_of.try_emplace(key, std::uint32_t(tiles_.size()));
            if (inserted) {
              tiles_.emplace_back();
              coords.push_back({x >> 4, y >> 4, z >> 4});
            }
            tiles_[t->second][local(x, y, z)] = kFree | kSite | pack(keyOf(s.x()), keyOf(s.y()), keyOf(s.z()));
          }
    }
    int lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
    for (const auto& c : coords)
      for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], c[a]); hi[a] = std::max(hi[a], c[a]); }
    for (int a = 0; a < 3; ++a) { bmin_[a] = lo[a]; bdim_[a] = hi[a] - lo[a] + 1; }
    index_.assign(std::size_t(bdim_[0]) * std::size_t(bdim_[1]) * std::size_t(bdim_[2]), -1);
    for (std::size_t i = 0; i < coords.size(); ++i)
      index_[(std::size_t(coords[i][2] - lo[2]) * std::size_t(bdim_[1]) + std::size_t(coords[i][1] - lo[1])) *
                 std::size_t(bdim_[0]) + std::size_t(coords[i][0] - lo[0])] = std::int32_t(i);
    bytes_ = tiles_.size() * sizeof(Tile) + index_.size() * 4 + coords.size() * 12;
  }
  std::uint64_t memoryBytes() const { return bytes_; }

  DistanceSample query(const Vec3& p) const noexcept {
    DistanceSample out;
    out.nearest = p;
    const double px = p.x(), py = p.y(), pz = p.z();
    const double lim = 32767.0 * res_;
    if (!(std::abs(px) <= lim && std::abs(py) <= lim && std::abs(pz) <= lim)) return out;
    const double ux = px * inv_, uy = py * inv_, uz = pz * inv_;
    const int base[3] = {floorToInt(ux - 0.5) + 32768, floorToInt(uy - 0.5) + 32768, floorToInt(uz - 0.5) + 32768};
    std::uint64_t words[8];
    if ((base[0] & 15) != 15 && (base[1] & 15) != 15 && (base[2] & 15) != 15) {
      const std::int32_t b = tileIndex(base[0] >> 4, base[1] >> 4, base[2] >> 4);
      if (b < 0) return out;
      const std::uint64_t* blk = tiles_[std::size_t(b)].data() + local(base[0], base[1], base[2]);
      words[0] = blk[0];        words[1] = blk[1];
      words[2] = blk[16];       words[3] = blk[17];
      words[4] = blk[256];      words[5] = blk[257];
      words[6] = blk[256 + 16]; words[7] = blk[256 + 17];
    } else {
      gather(base, words);
    }
    const double qx = ux - double(base[0] - 32768) - 0.5;
    const double qy = uy - double(base[1] - 32768) - 0.5;
    const double qz = uz - double(base[2] - 32768) - 0.5;
    const int own_corner = (qx >= 0.5 ? 1 : 0) | (qy >= 0.5 ? 2 : 0) | (qz >= 0.5 ? 4 : 0);
    if (!(words[own_corner] & kFree)) return out;
    double best = std::numeric_limits<double>::infinity();
    double bx = 0, by = 0, bz = 0;
    for (int c = 0; c < 8; ++c) {
      const std::uint64_t w = words[c];
      const bool free = w & kFree;
      const double sx = free ? double(coord(w, 0) - base[0]) : double(c & 1);
      const double sy = free ? double(coord(w, 1) - base[1]) : double((c >> 1) & 1);
      const double sz = free ? double(coord(w, 2) - base[2]) : double(c >> 2);
      const double ex = std::max(std::abs(qx - sx) - 0.5, 0.0);
      const double ey = std::max(std::abs(qy - sy) - 0.5, 0.0);
      const double ez = std::max(std::abs(qz - sz) - 0.5, 0.0);
      const double d2 = (free && !(w & kSite)) ? std::numeric_limits<double>::infinity() : ex * ex + ey * ey + ez * ez;
      const bool better = d2 < best;
      best = better ? d2 : best;
      bx = better ? std::copysign(ex, qx - sx) : bx;
      by = better ? std::copysign(ey, qy - sy) : by;
      bz = better ? std::copysign(ez, qz - sz) : bz;
    }
    if (!(best < std::numeric_limits<double>::infinity())) return out;
    out.in_rock = false;
    out.distance = std::sqrt(best) * res_;
    const double dx = bx * res_, dy = by * res_, dz = bz * res_;
    out.nearest = Vec3(px - dx, py - dy, pz - dz);
    if (out.distance > 0) {
      const double r = 1.0 / out.distance;
      out.gradient = Vec3(dx * r, dy * r, dz * r);
    }
    return out;
  }

 private:
  using Tile = std::array<std::uint64_t, 4096>;
  static constexpr std::uint64_t kFree = std::uint64_t{1} << 48, kSite = std::uint64_t{1} << 49;
  static int floorToInt(double v) {
    const int i = static_cast<int>(v);
    return i - (static_cast<double>(i) > v);
  }
  static int local(int x, int y, int z) { return (x & 15) | ((y & 15) << 4) | ((z & 15) << 8); }
  static std::uint64_t pack(int x, int y, int z) {
    return std::uint64_t(std::uint16_t(x)) | (std::uint64_t(std::uint16_t(y)) << 16) | (std::uint64_t(std::uint16_t(z)) << 32);
  }
  static int coord(std::uint64_t w, int a) { return int((w >> (16 * a)) & 0xFFFF); }
  int keyOf(double c) const { return floorToInt(c * inv_) + 32768; }
  Vec3 centre(int x, int y, int z) const {
    return {(x - 32768 + 0.5) * res_, (y - 32768 + 0.5) * res_, (z - 32768 + 0.5) * res_};
  }
  std::int32_t tileIndex(int bx, int by, int bz) const {
    const int x = bx - bmin_[0], y = by - bmin_[1], z = bz - bmin_[2];
    if (unsigned(x) >= unsigned(bdim_[0]) || unsigned(y) >= unsigned(bdim_[1]) || unsigned(z) >= unsigned(bdim_[2]))
      return -1;
    return index_[(std::size_t(z) * std::size_t(bdim_[1]) + std::size_t(y)) * std::size_t(bdim_[0]) + std::size_t(x)];
  }
  [[gnu::noinline, gnu::cold]] void gather(const int base[3], std::uint64_t words[8]) const {
    for (int c = 0; c < 8; ++c) {
      const int x = base[0] + (c & 1), y = base[1] + ((c >> 1) & 1), z = base[2] + (c >> 2);
      const std::int32_t b = tileIndex(x >> 4, y >> 4, z >> 4);
      words[c] = b < 0 ? 0 : tiles_[std::size_t(b)][std::size_t(local(x, y, z))];
    }
  }

  double res_, inv_;
  int bmin_[3] = {0, 0, 0}, bdim_[3] = {0, 0, 0};
  std::vector<std::int32_t> index_;
  std::vector<Tile> tiles_;
  std::uint64_t bytes_ = 0;
};

const WideField& wideDistrict() {
  static const WideField f = [] {
    WideField wide(district().map, district().field);
    // Both layouts hold the same sites, so they must answer alike, bit for bit.
    int differ = 0;
    for (const std::vector<Vec3>* pts : {&district().random_free, &district().path})
      for (const Vec3& p : *pts) differ += wide.query(p).distance != district().field.query(p).distance;
    if (differ) { std::fprintf(stderr, "the wide layout disagrees at %d points\n", differ); std::abort(); }
    return wide;
  }();
  return f;
}

void reportLayout(benchmark::State& state, std::uint64_t bytes, std::uint64_t free_voxels) {
  state.counters["bytes_per_free_voxel"] = double(bytes) / double(free_voxels);
  state.counters["MiB"] = double(bytes) / (1 << 20);
}

// Random lookups over the whole district: the field's size against the cache decides these.
void BM_DistanceField_RandomPoints(benchmark::State& state) {
  World& w = district();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(w.field.query(w.random_free[i++ & 0xFFFF]));
  }
  state.SetItemsProcessed(state.iterations());
  reportLayout(state, w.field.stats().memory_bytes, w.field.stats().free_voxels);
}
BENCHMARK(BM_DistanceField_RandomPoints);

// Every roadway at 5 cm steps, one field read a step.
template <typename Read>
void walkPath(benchmark::State& state, Read read) {
  World& w = district();
  std::size_t i = 0;
  const std::size_t n = w.path.size();
  for (auto _ : state) {
    benchmark::DoNotOptimize(read(w.field, w.path[i]));
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_DistanceField_AlongPath(benchmark::State& state) {
  walkPath(state, [](const DistanceField& f, const Vec3& p) { return f.query(p); });
  reportLayout(state, district().field.stats().memory_bytes, district().field.stats().free_voxels);
}
BENCHMARK(BM_DistanceField_AlongPath);

// The distance alone (a cost integral's samples), the same walk.
void BM_DistanceField_AlongPathDistanceOnly(benchmark::State& state) {
  walkPath(state, [](const DistanceField& f, const Vec3& p) { return f.distance(p); });
}
BENCHMARK(BM_DistanceField_AlongPathDistanceOnly);

// The same two walks over the wide layout, for the ratios at the end.
void BM_WideLayout_RandomPoints(benchmark::State& state) {
  World& w = district();
  const WideField& f = wideDistrict();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.query(w.random_free[i++ & 0xFFFF]));
  }
  state.SetItemsProcessed(state.iterations());
  reportLayout(state, f.memoryBytes(), w.field.stats().free_voxels);
}
BENCHMARK(BM_WideLayout_RandomPoints);

void BM_WideLayout_AlongPath(benchmark::State& state) {
  World& w = district();
  const WideField& f = wideDistrict();
  std::size_t i = 0;
  const std::size_t n = w.path.size();
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.query(w.path[i]));
    if (++i == n) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  reportLayout(state, f.memoryBytes(), w.field.stats().free_voxels);
}
BENCHMARK(BM_WideLayout_AlongPath);

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

void BM_WideLayout_AlongPathWarm(benchmark::State& state) {
  const WideField& f = wideDistrict();
  std::vector<Vec3> stretch;
  for (double x = 100.0; x < 120.0; x += 0.01) stretch.push_back(Vec3(x, 0.5, -3.0));
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.query(stretch[i]));
    if (++i == stretch.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_WideLayout_AlongPathWarm);

// A ground robot's view each period (local::LocalPlanner's scanBand): the floor under it, the
// floor's plane over 2.5 m about it and the 2.5-D band scan out to 2.61 m (the bundled tracked
// robot: 1.0 x 0.7 x 0.6 m, 15 degree slopes, 0.1 m steps), its centre 0.3 m above the floor,
// advancing 5 cm a period along every roadway. The scan with its cache (what the planner runs)
// and the reference that reads every voxel, in one run.
struct GroundView {
  std::vector<Vec3> at;       // the robot's centre
  std::vector<double> floor;  // the floor's top under it
};
const GroundView& groundView() {
  static GroundView g = [] {
    World& w = district();
    GroundView out;
    for (const Vec3& p : w.path) {
      const Vec3 c = p - Vec3(0, 0, 0.9);
      const std::optional<double> f = floorBelow(w.field, c + Vec3(0, 0, 0.1), 0.3 + 0.1 + 0.4);
      if (!f) continue;
      out.at.push_back(c);
      out.floor.push_back(*f);
    }
    return out;
  }();
  return g;
}
constexpr double kBandRadius = 2.61, kBandStep = 0.1, kBandHeight = 0.6;
const double kBandSlope = std::tan(15.0 * 3.14159265358979323846 / 180.0);

void bandScans(benchmark::State& state, bool cached) {
  World& w = district();
  const GroundView& g = groundView();
  BandCache cache;
  if (cached && !cache.reserve(w.field.resolution(), kBandRadius, kBandStep, kBandSlope, kBandHeight)) std::abort();
  BandBody body;
  body.reach = 0.61 + 0.05 + 0.25;
  body.clearance = kBandStep + w.field.resolution();
  BandScan scan;
  std::size_t i = 0, hits = 0;
  for (auto _ : state) {
    rockInBand(w.field, g.at[i], kBandRadius, g.floor[i], kBandStep, kBandSlope, kBandHeight, scan, 1u << 16,
               cached ? &cache : nullptr, &body);
    for (double d : scan.distance) hits += std::isfinite(d);
    if (++i == g.at.size()) i = 0;
  }
  state.counters["bins_hit"] = double(hits) / double(state.iterations());
  state.SetItemsProcessed(state.iterations());
}
void BM_BandScan_Cached(benchmark::State& state) { bandScans(state, true); }
BENCHMARK(BM_BandScan_Cached)->Unit(benchmark::kMicrosecond);
void BM_BandScan_EveryVoxel(benchmark::State& state) { bandScans(state, false); }
BENCHMARK(BM_BandScan_EveryVoxel)->Unit(benchmark::kMicrosecond);

// The floor's plane over 2.5 m about the robot, read voxel by voxel and through the band scan's
// cache (as the local planner reads it, before each scan).
void floorSlopes(benchmark::State& state, bool cached) {
  World& w = district();
  const GroundView& g = groundView();
  BandCache cache;
  if (cached && !cache.reserve(w.field.resolution(), kBandRadius, kBandStep, kBandSlope, kBandHeight)) std::abort();
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(floorSlope(w.field, Vec3(g.at[i].x(), g.at[i].y(), g.floor[i]), 0.0, 2.5, kBandSlope,
                                        kBandStep, 9, cached ? &cache : nullptr));
    if (++i == g.at.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
void BM_FloorSlope(benchmark::State& state) { floorSlopes(state, false); }
BENCHMARK(BM_FloorSlope)->Unit(benchmark::kMicrosecond);
void BM_FloorSlope_Cached(benchmark::State& state) { floorSlopes(state, true); }
BENCHMARK(BM_FloorSlope_Cached)->Unit(benchmark::kMicrosecond);

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
  state.counters["tile_edge"] = double(s.tile_edge_voxels);
  state.counters["far_sites"] = double(s.far_sites);
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
      const double x = a->second / b->second;
      if (x < 10)
        std::printf("  %-62s %10.2fx  (%.1f ns vs %.1f ns)\n", what, x, b->second, a->second);
      else
        std::printf("  %-62s %10.0fx  (%.1f ns vs %.1f ns)\n", what, x, b->second, a->second);
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
    ratio("BM_WideLayout_RandomPoints", "BM_DistanceField_RandomPoints",
          "16^3 tiles of 8-byte words / compact field (random)");
    ratio("BM_WideLayout_AlongPath", "BM_DistanceField_AlongPath", "16^3 tiles of 8-byte words / compact field (path)");
    ratio("BM_BandScan_EveryVoxel", "BM_BandScan_Cached", "band scan reading every voxel / with its cache");
    ratio("BM_FloorSlope", "BM_FloorSlope_Cached", "floor's plane reading every voxel / through the cache");
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
