// SPDX-License-Identifier: BSD-3-Clause
// The local step in the bundled district with 0, 5, 20 and 50 moving obstacles, beside the
// classic APF that reads the rock distance from fcl::OcTree (FclOctreeDistance), measured in the
// same run; the ratio baseline / adit is printed at the end. Not run by CTest.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "adit/local/local_planner.hpp"
#include "adit/local/potential_terms.hpp"
#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/map_io.hpp"

namespace {

using namespace adit;
using namespace adit::local;
using adit::map::Vec3;

struct District {
  map::OccupancyMap map;
  map::DistanceField field;
  map::FclOctreeDistance fcl;
  std::vector<Vec3> robot_positions;  // along the main haulage roadway, 1.9 m above the floor
};

District& district() {
  static District d = [] {
    StatusOr<map::OccupancyMap> m = map::loadMap(std::string(ADIT_MAPS_DIR) + "/district.bt");
    if (!m.ok()) std::abort();
    StatusOr<map::DistanceField> f = map::DistanceField::build(*m);
    StatusOr<map::FclOctreeDistance> fcl = map::FclOctreeDistance::create(*m);
    if (!f.ok() || !fcl.ok()) std::abort();
    District out{std::move(*m), std::move(*f), std::move(*fcl), {}};
    for (double x = 25; x < 79; x += 0.05) out.robot_positions.push_back(Vec3(x, 0.3 * std::sin(x), 0.575 - 0.051 * (x - 25)));
    return out;
  }();
  return d;
}

std::vector<map::MovingObstacle> movers(int n) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<map::MovingObstacle> out(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    map::MovingObstacle& m = out[std::size_t(i)];
    m.shape = i % 2 ? map::RobotShape::sphere(0.4) : map::RobotShape::box(Vec3(1.5, 1.0, 1.2));
    m.position = Vec3(25 + 55 * (0.5 + 0.5 * u(rng)), 1.5 * u(rng), 0.575 - 0.051 * 30);
    m.velocity = Vec3(0.5 * u(rng), 0.1 * u(rng), 0);
  }
  return out;
}

std::map<std::string, double> g_ns_per_step;  // for the ratios printed at the end

// This thread's CPU time: the machines are shared, so the ratio compares CPU, not wall, time.
double threadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e9 + double(ts.tv_nsec);
}

void recordNs(benchmark::State& state, const std::string& name, double total_ns) {
  g_ns_per_step[name] = total_ns / double(state.iterations());
}

// `step_ns`, when given, receives each step's CPU time (up to its capacity; timing every step costs
// two clock reads, so only the spread benchmark asks).
void runSteps(benchmark::State& state, Method method, const std::string& record_as, bool envelope = true,
              int n_movers = -1, bool ground = false, std::vector<double>* step_ns = nullptr) {
  District& d = district();
  World w;
  w.field = &d.field;
  LocalParams params = LocalParams::preset(method);
  params.envelope.enabled = envelope;
  params.envelope.sight_switch = envelope;
  // The bundled ground rescue's robot: tracked, 1.0 x 0.7 x 0.6 m, its centre 0.3 m above the floor
  // (the flying positions are 1.9 m above it), pursuing the path where it is clear.
  const double drop = ground ? 1.9 - 0.3 : 0.0;
  if (ground) params.robot = RobotLimits::trackedRescue();
  StatusOr<LocalPlanner> p = LocalPlanner::create(params, w);
  if (!p.ok()) std::abort();
  const std::vector<map::MovingObstacle> mov =
      movers(n_movers >= 0 ? n_movers : record_as.empty() ? 20 : int(state.range(0)));
  const map::Polyline path{{Vec3(25, 0, 0.575 - drop), Vec3(80, 0, -2.23 - drop)}};
  std::size_t i = 0;
  long stuck_or_arrived = 0;
  const double t0 = threadCpuNs();
  for (auto _ : state) {
    // The robot advances 5 cm per period along the roadway; at the end it starts again with a
    // fresh monitor, so that every period is a real step (a stuck or arrived planner only brakes).
    if (i == d.robot_positions.size()) {
      i = 0;
      p->reset();
    }
    RobotState s;
    s.position = d.robot_positions[i++] - Vec3(0, 0, drop);
    s.velocity = Vec3(0.5, 0, -0.025);
    const double t_step = step_ns ? threadCpuNs() : 0.0;
    StepCommand c = p->step(s, path, mov.data(), mov.size(), 0.1);
    if (step_ns && step_ns->size() < step_ns->capacity()) step_ns->push_back(threadCpuNs() - t_step);
    stuck_or_arrived += c.status == StepStatus::kStuck || c.status == StepStatus::kArrived;
    benchmark::DoNotOptimize(c);
  }
  state.counters["stuck_or_arrived"] = double(stuck_or_arrived) / double(state.iterations());
  if (!record_as.empty())
    recordNs(state, record_as, threadCpuNs() - t0);
}

void BM_LocalStep(benchmark::State& state) { runSteps(state, Method::kTian2016, "adit/" + std::to_string(state.range(0))); }
BENCHMARK(BM_LocalStep)->Arg(0)->Arg(5)->Arg(20)->Arg(50);

// The safety envelope's cost (EnvelopeParams): the same 20-mover steps without it and with it,
// side by side in one run.
void BM_LocalStepEnvelope(benchmark::State& state) {
  const bool on = state.range(0) != 0;
  state.SetLabel(on ? "envelope on" : "envelope off");
  runSteps(state, Method::kTian2016, on ? "envelope-on" : "envelope-off", on, 20);
}
BENCHMARK(BM_LocalStepEnvelope)->Arg(0)->Arg(1);

// Ground mode (band scan, pursuit, drive command, the drive's stopping runs) beside the flying
// step, both with the envelope and 20 movers, in one run.
void BM_LocalStepGround(benchmark::State& state) {
  const bool ground = state.range(0) != 0;
  state.SetLabel(ground ? "ground, tracked" : "fly");
  runSteps(state, Method::kTian2016, ground ? "ground-20" : "fly-20", true, 20, ground);
}
BENCHMARK(BM_LocalStepGround)->Arg(0)->Arg(1);

// The ground step's spread (a robot's control period must hold its worst step, not its mean):
// each step's CPU time over the same walk, as percentiles. The periods that follow the floor down
// a voxel remake the band's tables and are the slowest.
void BM_LocalStepGroundLatency(benchmark::State& state) {
  std::vector<double> ns;
  ns.reserve(1u << 20);
  runSteps(state, Method::kTian2016, "", true, 20, true, &ns);
  // The first step fills the band's cache (every column's voxels read once): apart.
  if (!ns.empty()) {
    state.counters["first_us"] = ns.front() / 1e3;
    ns.erase(ns.begin());
  }
  std::sort(ns.begin(), ns.end());
  auto at = [&](double q) { return ns.empty() ? 0.0 : ns[std::min(ns.size() - 1, std::size_t(q * double(ns.size())))]; };
  state.counters["p50_us"] = at(0.5) / 1e3;
  state.counters["p99_us"] = at(0.99) / 1e3;
  state.counters["p999_us"] = at(0.999) / 1e3;
  state.counters["max_us"] = ns.empty() ? 0.0 : ns.back() / 1e3;
}
BENCHMARK(BM_LocalStepGroundLatency)->Unit(benchmark::kMicrosecond);

// The models that sum over every rock surface point in range (rockSurfacePoints), 20 obstacles.
void BM_LocalStepModel(benchmark::State& state) {
  const Method m = static_cast<Method>(state.range(0));
  state.SetLabel(methodName(m));
  runSteps(state, m, "");
}
BENCHMARK(BM_LocalStepModel)
    ->Arg(int(Method::kClassic))->Arg(int(Method::kWang2014))->Arg(int(Method::kVff))->Arg(int(Method::kCvff))
    ->Arg(int(Method::kUuv))->Unit(benchmark::kMicrosecond);

// Baseline: Khatib's APF with the rock distance from fcl::OcTree (nearest occupied voxel) and the
// moving obstacles as spheres of their bounding radius.
void BM_ClassicFclOctree(benchmark::State& state) {
  District& d = district();
  const std::vector<map::MovingObstacle> mov = movers(int(state.range(0)));
  const ClassicParams prm;
  const map::RobotShape robot = map::RobotShape::sphere(0.3);
  const Vec3 goal(80, 0, -2.23);
  std::size_t i = 0;
  const double t0 = threadCpuNs();
  for (auto _ : state) {
    const Vec3 q = d.robot_positions[i++ % d.robot_positions.size()];
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = q;
    const map::ShapeDistance rock = d.fcl.distance(robot, pose);
    TermValue f = classicAttraction(q, goal, prm.xi);
    if (rock.exact && map::allFinite(rock.point_on_obstacle))
      f += classicRepulsion(pointProximity(q, rock.point_on_obstacle, robot.radius), prm.eta, prm.rho0_m);
    for (const map::MovingObstacle& m : mov)
      f += classicRepulsion(sphereProximity(q, m.position, m.shape.boundingRadius(), robot.radius), prm.eta, prm.rho0_m);
    benchmark::DoNotOptimize(f);
  }
  recordNs(state, "fcl/" + std::to_string(state.range(0)),
           threadCpuNs() - t0);
}
BENCHMARK(BM_ClassicFclOctree)->Arg(0)->Arg(5)->Arg(20)->Arg(50)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  std::printf("\nRatios measured in this run, CPU time per step (classic APF on fcl::OcTree / adit tian2016):\n");
  for (int n : {0, 5, 20, 50}) {
    const auto a = g_ns_per_step.find("adit/" + std::to_string(n)), b = g_ns_per_step.find("fcl/" + std::to_string(n));
    if (a == g_ns_per_step.end() || b == g_ns_per_step.end()) continue;
    std::printf("  %2d moving obstacles: adit %8.2f us, baseline %8.1f us, ratio %6.0fx\n", n, a->second / 1e3,
                b->second / 1e3, b->second / a->second);
  }
  const auto off = g_ns_per_step.find("envelope-off"), on = g_ns_per_step.find("envelope-on");
  if (off != g_ns_per_step.end() && on != g_ns_per_step.end())
    std::printf("  safety envelope, 20 moving obstacles: off %.2f us, on %.2f us per step, ratio %.2fx\n",
                off->second / 1e3, on->second / 1e3, on->second / off->second);
  const auto fly = g_ns_per_step.find("fly-20"), gnd = g_ns_per_step.find("ground-20");
  if (fly != g_ns_per_step.end() && gnd != g_ns_per_step.end())
    std::printf("  ground mode, 20 moving obstacles, envelope on: fly %.2f us, ground %.2f us per step, ratio %.2fx\n",
                fly->second / 1e3, gnd->second / 1e3, gnd->second / fly->second);
  benchmark::Shutdown();
  return 0;
}
