// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The grid optimum: a 26-connected A* over voxel centres that the robot may occupy (the
/// "inflated free space"), with no corner cutting (a diagonal move needs every voxel of the
/// 2x2 or 2x2x2 block it spans). It is the yardstick the global planner's path lengths are
/// measured against (tests, `adit bench global`), not a planner adit ships: its paths zig-zag
/// at 45 degrees and are a few percent longer than the any-angle optimum.
///
///   GridPathResult g = gridOptimum([&](const Vec3& c) { return planner.stateValid(c); },
///                                  res, start, goal);
///   double ratio = plan.length_m / g.length_m;

#include <cstdint>
#include <functional>

#include "adit/map/types.hpp"
#include "adit/status.hpp"

namespace adit::global {

struct GridPathResult {
  bool found = false;
  double length_m = 0.0;            ///< start -> its voxel centre -> ... -> goal's centre -> goal
  map::Polyline path;               ///< voxel centres, with start and goal at the ends
  std::uint64_t expanded = 0;       ///< A* expansions
};

/// `valid(c)` answers for voxel centres c = ((i + 0.5) res, (j + 0.5) res, (k + 0.5) res).
/// Start and goal must lie in valid voxels. Gives up (found = false) after `max_expansions`.
StatusOr<GridPathResult> gridOptimum(const std::function<bool(const map::Vec3&)>& valid, double resolution_m,
                                     const map::Vec3& start, const map::Vec3& goal,
                                     std::uint64_t max_expansions = 50'000'000);

}  // namespace adit::global
