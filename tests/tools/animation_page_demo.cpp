// SPDX-License-Identifier: BSD-3-Clause
// Helper of the browser tests (browser_page.cmake), not a user tool:
//   animation_page_demo write OUT.html [FRAMES [MOVERS]]
//       a page of a scripted, kinematic run (no planner: the robot follows the Tian 2016 expected
//       path of the scenario and slows down near the moving obstacles), drawn over a real
//       Figure, so that the browser has a page to play before any simulator exists;
//   animation_page_demo check-png SHOT.png [RRGGBB MIN_PIXELS]
//       fails (exit 1) when a screenshot is blank: too few colours or nearly one colour; with a
//       colour, also when fewer than MIN_PIXELS pixels have exactly that colour.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "adit/map/types.hpp"
#include "common/animation_page.hpp"
#include "common/figure.hpp"

namespace {

using adit::map::Vec3;
using namespace adit::tools;

/// Position at time t of an obstacle under constant acceleration, as the scenario schema says.
Vec3 moverAt(const Vec3& p0, const Vec3& v, const Vec3& a, double t) { return p0 + v * t + 0.5 * a * t * t; }

int writeDemo(const std::string& out, std::size_t frames, std::size_t movers) {
  const std::vector<Vec3> path = {{0, 0, 0}, {4.9, 5, 0}, {10.8, 6.2, 0}, {14, 14, 0}};
  struct Mover {
    Vec3 p0, v, a;
    double r;
  };
  // The example obstacle first, then others crossing the path at different times.
  std::vector<Mover> ms = {{{4, 8, 0}, {0.25, -0.35, 0}, {0.036, 0.16, 0}, 0.3}};
  for (std::size_t k = 1; k < movers; ++k) {
    const double s = static_cast<double>(k);
    ms.push_back({{15.5 - std::fmod(1.7 * s, 9.0), -1.0 + std::fmod(2.9 * s, 15.0), 0},
                  {-0.12 * std::cos(s), 0.1 * std::sin(1.3 * s), 0},
                  {0.002 * std::sin(s), -0.001 * std::cos(s), 0},
                  0.25 + 0.05 * static_cast<double>(k % 3)});
  }
  ms.resize(movers);

  AnimationPageInput in;
  in.title = "synthetic run (page demo, no planner)";
  in.robot_radius_m = 0.3;
  for (std::size_t k = 0; k < movers; ++k) in.movers.push_back({"obstacle " + std::to_string(k + 1), ms[k].r, kFigureMoving});

  const double dt = 0.1;
  std::size_t seg = 0;
  Vec3 pos = path[0];
  double speed = 0.0, travelled = 0.0, min_gap = 1e9;
  for (std::size_t i = 0; i < frames; ++i) {
    const double t = dt * static_cast<double>(i);
    PageFrame f;
    f.t_s = t;
    double nearest = 1e9;
    for (const Mover& m : ms) {
      f.movers.push_back(moverAt(m.p0, m.v, m.a, t));
      nearest = std::min(nearest, (f.movers.back() - pos).head<2>().norm() - m.r - in.robot_radius_m);
    }
    min_gap = std::min(min_gap, nearest);
    const bool arrived = (pos - path.back()).norm() < 0.05;
    const bool yielding = !arrived && nearest < 2.0;
    const double target = arrived ? 0.0 : (yielding ? 0.25 : 1.0);
    speed += std::clamp(target - speed, -0.5 * dt, 0.5 * dt);  // a_max 0.5 m/s^2
    f.robot = pos;
    f.status = arrived ? "arrived" : (yielding ? "yielding" : "following");
    in.frames.push_back(f);
    double step = speed * dt;
    while (step > 0 && seg + 1 < path.size()) {
      const Vec3 to = path[seg + 1] - pos;
      if (to.norm() > step) {
        pos += to.normalized() * step;
        travelled += step;
        break;
      }
      travelled += to.norm();
      step -= to.norm();
      pos = path[++seg];
    }
  }

  // A replay's layers (scripted, as the run is): a roof fall beside the path at 8 s, the rock of
  // it "sensed" from 9 s on, a replan at 12 s to a second path, a sub-goal every 2 s, the end.
  in.initial_path = path;
  const Vec3 fall(12.2, 9.0, 0);
  const double t_last = in.frames.back().t_s;
  if (t_last >= 8.0) in.events.push_back({8.0, "roof_fall", "ball of r = 1.5 m (scripted)", "", fall, 1.5, {}});
  if (t_last >= 12.0)
    in.events.push_back({12.0, "replan", "expected path blocked (scripted)", "replanning", Vec3::Zero(), 0.0,
                         {in.frames[120].robot, Vec3(10.0, 9.5, 0), path.back()}});
  in.events.push_back({t_last, "end", "last frame", "", Vec3::Zero(), 0.0, {}});
  for (int k = 0; k < 24; ++k) {
    const double a = 2.0 * M_PI * k / 24.0;
    if (9.0 + 0.1 * k <= t_last) in.sensed.push_back({9.0 + 0.1 * k, fall + 1.5 * Vec3(std::cos(a), std::sin(a), 0)});
  }
  for (std::size_t i = 0; i < in.frames.size(); i += 20) {
    const std::size_t ahead = std::min(i + 15, in.frames.size() - 1);
    in.subgoals.push_back({in.frames[i].t_s, in.frames[ahead].robot});
  }

  Figure fig;
  fig.setWorldBounds({Vec3(-2, -2, 0), Vec3(17, 16, 1)});
  fig.addDisc({Vec3(9, 11.5, 0), 0.5, kFigureObstacle, 0.55, kFigureObstacle, "", "static obstacle"});
  fig.addMarker({path.front(), MarkerShape::kCircle, kFigureStart, 10, "start", "start"});
  fig.addMarker({path.back(), MarkerShape::kSquare, kFigureGoal, 10, "goal", "goal"});

  in.summary = {{"kind", "scripted kinematics (not a planner run)"},
                {"frames", std::to_string(frames)},
                {"path driven", std::to_string(travelled).substr(0, 5) + " m"},
                {"closest approach", std::to_string(min_gap).substr(0, 5) + " m (surface to surface)"}};
  AnimationPageInfo info;
  const adit::Status s = writeAnimationPage(fig, in, out, &info);
  if (!s.ok()) {
    std::fprintf(stderr, "animation_page_demo: %s\n", s.message().c_str());
    return 2;
  }
  std::printf("%s: %zu frames, %zu movers, page %zu bytes (frame data %zu, picture %zu)\n", out.c_str(), info.frames,
              movers, info.page_bytes, info.frame_data_bytes, info.background_bytes);
  return 0;
}

int checkPng(const std::string& file, const std::string& colour_hex, long min_pixels) {
  cairo_surface_t* s = cairo_image_surface_create_from_png(file.c_str());
  if (cairo_surface_status(s) != CAIRO_STATUS_SUCCESS) {
    std::fprintf(stderr, "animation_page_demo: %s: cannot read PNG: %s\n", file.c_str(),
                 cairo_status_to_string(cairo_surface_status(s)));
    cairo_surface_destroy(s);
    return 1;
  }
  const int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
  const int stride = cairo_image_surface_get_stride(s);
  const unsigned char* data = cairo_image_surface_get_data(s);
  const std::uint32_t wanted = colour_hex.empty() ? 0 : static_cast<std::uint32_t>(std::stoul(colour_hex, nullptr, 16));
  std::map<std::uint32_t, long> histogram;
  long matching = 0;
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      const std::uint32_t px = *reinterpret_cast<const std::uint32_t*>(data + r * stride + 4 * c) & 0xFFFFFF;
      ++histogram[px];
      if (!colour_hex.empty() && px == wanted) ++matching;
    }
  }
  cairo_surface_destroy(s);
  long dominant = 0;
  for (const auto& [px, n] : histogram) dominant = std::max(dominant, n);
  const double other = 1.0 - static_cast<double>(dominant) / (static_cast<double>(w) * h);
  std::printf("%s: %d x %d px, %zu colours, %.1f %% not the dominant colour", file.c_str(), w, h, histogram.size(),
              100.0 * other);
  if (!colour_hex.empty()) std::printf(", %ld pixels of #%s", matching, colour_hex.c_str());
  std::printf("\n");
  if (histogram.size() < 64 || other < 0.05) {
    std::fprintf(stderr, "animation_page_demo: %s looks blank\n", file.c_str());
    return 1;
  }
  if (!colour_hex.empty() && matching < min_pixels) {
    std::fprintf(stderr, "animation_page_demo: %s has %ld pixels of #%s, expected at least %ld\n", file.c_str(),
                 matching, colour_hex.c_str(), min_pixels);
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string verb = argc > 1 ? argv[1] : "";
  if (verb == "write" && argc >= 3) {
    return writeDemo(argv[2], argc > 3 ? std::strtoul(argv[3], nullptr, 10) : 400,
                     argc > 4 ? std::strtoul(argv[4], nullptr, 10) : 3);
  }
  if (verb == "check-png" && (argc == 3 || argc == 5)) {
    return checkPng(argv[2], argc == 5 ? argv[3] : "", argc == 5 ? std::strtol(argv[4], nullptr, 10) : 0);
  }
  std::fprintf(stderr,
               "usage: animation_page_demo write OUT.html [FRAMES [MOVERS]]\n"
               "       animation_page_demo check-png SHOT.png [RRGGBB MIN_PIXELS]\n");
  return 2;
}
