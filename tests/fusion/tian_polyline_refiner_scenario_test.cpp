// SPDX-License-Identifier: BSD-3-Clause
// Tian, Gao, Zhang 2016, Figs. 10-15 (../shared/spec/algorithms.md §1.5): the break points of the
// polyline expected path from (0,0) to (14,14) past six static discs. The paper reports A = (4.9, 5.0)
// and B = (10.8, 6.2) but not its objective nor the disc radii. Here:
//  - radii from maps/scenarios/tian2016_polyline.yaml: discs 0.4 m, robot 0.1 m;
//  - objectives, nothing tuned toward A and B: (1) the refiner's default, length + w ∫ ½(1/c − 1/ρ0)² ds
//    with w = 1, ρ0 = 2 m (the local layer's Tian ρ0): it trades length for clearance among discs
//    2-3 m apart, so the path may get longer while the objective falls; (2) length alone (w = 0),
//    the shortest polyline with the same break-point count in Ω;
//  - starting polyline (0,0) → (5, 4.5) → (9.5, 9.75) → (14,14): each break point at the middle of
//    a gap between two discs, (4,6)–(6,3) and (9,11.5)–(10,8).
//    The paper's B lies in the other gap, (10,8)–(12,5). With 0.4 m discs and a 0.1 m robot no
//    two-break-point polyline through that gap is collision-free: the last leg to the goal passes
//    within 0.5 m of the disc (14,13), 1 m below the goal, or of (10,8) (from the paper's B it
//    passes 0.38 m from (14,13)'s centre; a grid search over B in [7,13]×[4,10] finds no valid B
//    right of (10,8)). So B cannot be reproduced with these radii, and the distances show it.
// Asserted: both results are collision-free with a lower objective, and (2) is shorter than the
// start; lengths, clearances and the distances to A and B are printed, not asserted.
#include <gtest/gtest.h>

#include <cstdio>
#include <limits>

#include "adit/fusion/break_point_refiner.hpp"

namespace adit::fusion {
namespace {

using map::Polyline;
using map::Vec3;

const std::vector<Vec3>& discCentres() {
  static const std::vector<Vec3> c = {{4, 6, 0}, {6, 3, 0}, {9, 11.5, 0}, {10, 8, 0}, {12, 5, 0}, {14, 13, 0}};
  return c;
}

// Robot surface (0.1 m) to the nearest disc surface (0.4 m).
double discClearance(const Vec3& p) {
  double c = std::numeric_limits<double>::infinity();
  for (const Vec3& o : discCentres()) c = std::min(c, (p - o).norm() - 0.4 - 0.1);
  return c;
}

BreakPointRefinement refineTian(double weight, const char* label) {
  BreakPointRefinerParams p;
  p.planar = true;
  p.clearance_weight = weight;
  p.min_clearance_m = 0.0;  // touching allowed, overlap not (the paper's robot is a point)
  p.sample_step_m = 0.02;
  const Polyline start{{Vec3(0, 0, 0), Vec3(5, 4.5, 0), Vec3(9.5, 9.75, 0), Vec3(14, 14, 0)}};
  const BreakPointRefinement r = refineBreakPoints(start, discClearance, p);
  EXPECT_EQ(r.outcome, RefineOutcome::kRefined) << r.message;
  if (r.path.size() != 4u) {
    ADD_FAILURE() << "expected two break points, got " << r.path.size() - 2;
    return r;
  }
  EXPECT_LT(r.objective_after, r.objective_before);
  EXPECT_GE(r.after.min_clearance_m, 0.0);
  // Collision-free, checked independently at 1 mm.
  for (std::size_t i = 0; i + 1 < r.path.size(); ++i) {
    const Vec3 a = r.path.points[i], b = r.path.points[i + 1];
    const int n = int(std::ceil((b - a).norm() / 0.001));
    for (int k = 0; k <= n; ++k) EXPECT_GE(discClearance(a + (b - a) * (double(k) / n)), -1e-9);
  }
  const Vec3 A(4.9, 5.0, 0), B(10.8, 6.2, 0);
  std::printf("Tian 2016 polyline, %s: start (0,0)-(5,4.5)-(9.5,9.75)-(14,14), length %.3f -> %.3f m, min clearance "
              "%.3f -> %.3f m, mean %.3f -> %.3f m, objective %.3f -> %.3f\n",
              label, r.before.length_m, r.after.length_m, r.before.min_clearance_m, r.after.min_clearance_m,
              r.before.mean_clearance_m, r.after.mean_clearance_m, r.objective_before, r.objective_after);
  std::printf("  A' = (%.3f, %.3f), %.3f m from A = (4.9, 5.0); B' = (%.3f, %.3f), %.3f m from B = (10.8, 6.2)\n",
              r.path.points[1].x(), r.path.points[1].y(), (r.path.points[1] - A).norm(), r.path.points[2].x(),
              r.path.points[2].y(), (r.path.points[2] - B).norm());
  return r;
}

TEST(TianPolylineScenario, LengthAndClearanceObjective) { refineTian(1.0, "length + clearance penalty (w = 1)"); }

TEST(TianPolylineScenario, LengthOnlyIsShorter) {
  const BreakPointRefinement r = refineTian(0.0, "length only (w = 0)");
  EXPECT_LT(r.after.length_m, r.before.length_m);
}

}  // namespace
}  // namespace adit::fusion
