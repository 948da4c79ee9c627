// SPDX-License-Identifier: BSD-3-Clause
// Import benchmarks. Run: build/tests/bench/adit_import_bench [--benchmark_filter=...]
// A registered scan of a 200 m roadway (1.1 M points, 5 cm spacing) becomes occupied voxels;
// OctoMap's insertPointCloud (ray casting from the scanner on the centreline) on the same
// points is the baseline in the same run. Items = points (or triangles for the mesh).
#include <benchmark/benchmark.h>
#include <octomap/OcTree.h>

#include <cstdio>
#include <cstdlib>

#include "adit/map/free_space.hpp"
#include "support/synthetic_scan.hpp"

namespace {

using namespace adit;
using namespace adit::map;

const std::vector<Vec3>& registeredScan() {
  static const std::vector<Vec3> pts = [] {
    test::TubeScan t;
    t.length = 200;
    t.width = 4.5;
    t.height = 3.5;
    t.spacing = 0.05;
    return t.points();
  }();
  return pts;
}

void BM_OccupiedVoxels(benchmark::State& state) {
  const auto& pts = registeredScan();
  std::size_t voxels = 0;
  for (auto _ : state) {
    voxels = occupiedVoxelKeys(pts, 0.2).size();
    benchmark::DoNotOptimize(voxels);
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * pts.size()));
  state.counters["voxels"] = double(voxels);
}
BENCHMARK(BM_OccupiedVoxels)->Unit(benchmark::kMillisecond);

// The whole import: surface voxels, distance band, seed flood, octree.
void BM_ImportSeedFlood(benchmark::State& state) {
  Geometry g;
  g.points = registeredScan();
  ImportParams p;
  p.resolution_m = 0.2;
  p.seed = Vec3(100, 0, 1.5);
  for (auto _ : state) {
    StatusOr<ImportResult> r = buildMapFromGeometry(g, p);
    if (!r.ok()) { std::fprintf(stderr, "%s\n", r.status().message().c_str()); std::abort(); }
    benchmark::DoNotOptimize(r->free_voxels);
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * g.points.size()));
}
BENCHMARK(BM_ImportSeedFlood)->Unit(benchmark::kMillisecond);

// Baseline: OctoMap's ray insertion, the scan in 10 m pieces each seen from its centre (a
// registered cloud has no single sensor origin; ray casting needs one).
void BM_OctomapInsertPointCloud(benchmark::State& state) {
  const auto& pts = registeredScan();
  std::vector<octomap::Pointcloud> pieces(20);
  for (const Vec3& p : pts) pieces[std::min<std::size_t>(19, std::size_t(p.x() / 10))].push_back(float(p.x()), float(p.y()), float(p.z()));
  for (auto _ : state) {
    octomap::OcTree tree(0.2);
    for (std::size_t i = 0; i < pieces.size(); ++i)
      tree.insertPointCloud(pieces[i], octomap::point3d(float(10 * i + 5), 0.f, 1.75f));
    benchmark::DoNotOptimize(tree.size());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * pts.size()));
}
BENCHMARK(BM_OctomapInsertPointCloud)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_MeshVoxels(benchmark::State& state) {
  // The tube as a mesh of many small triangles (0.5 m), like a scanned-surface mesh.
  Geometry m;
  const int nx = 400, ns = 30;  // 200 m / 0.5 m along, 15 m of perimeter / 0.5 m
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ns; ++j) {
      const double s = 15.0 * j / ns;  // unrolled perimeter: floor, wall, roof, wall
      const Vec3 p = s < 4.5 ? Vec3(0, s - 2.25, 0) : s < 8 ? Vec3(0, 2.25, s - 4.5) : s < 12.5 ? Vec3(0, 2.25 - (s - 8), 3.5)
                                                                                                 : Vec3(0, -2.25, 3.5 - (s - 12.5));
      m.points.push_back(p + Vec3(0.5 * i, 0, 0));
    }
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ns; ++j) {
      const std::uint32_t a = std::uint32_t(i * (ns + 1) + j), b = a + 1, c = a + std::uint32_t(ns + 1), d = c + 1;
      m.triangles.push_back({a, b, d});
      m.triangles.push_back({a, d, c});
    }
  for (auto _ : state) {
    StatusOr<std::vector<VoxelKey>> k = meshVoxelKeys(m, 0.2);
    benchmark::DoNotOptimize(k->size());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations() * m.triangles.size()));
}
BENCHMARK(BM_MeshVoxels)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
