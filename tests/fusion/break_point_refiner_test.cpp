// SPDX-License-Identifier: BSD-3-Clause
// The break-point refiner on a generated roadway bend: shorter, clear, re-validated, deterministic;
// corrupted input refused.
#include "adit/fusion/break_point_refiner.hpp"

#include <gtest/gtest.h>

#include <limits>

#include "adit/map/distance_field.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::fusion {
namespace {

using map::Polyline;
using map::Vec3;

constexpr double kRobotRadius = 0.4;

struct Bend {
  map::SurveyNetwork net = test::bentRoadway(map::CrossSection::rectangle(4.0, 3.0), 0.2);
  map::OccupancyMap map = test::voxelizeOrFail(net);
  map::DistanceField field = std::move(map::DistanceField::build(map)).value();
  // The centreline at mid-height (station z is the floor): a valid path with two break points.
  Polyline centreline{{Vec3(1.4, 0.5, 1.5), Vec3(8, 3, 1.9), Vec3(12, 10, 2.4), Vec3(18.5, 10.8, 2.5)}};
};

const Bend& bend() {
  static const Bend b;
  return b;
}

TEST(BreakPointRefiner, BendGetsShorterAndStaysClear) {
  const Bend& b = bend();
  const BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  const ClearanceFn c = fieldClearance(b.field, kRobotRadius);
  const BreakPointRefinement r = refineBreakPoints(b.centreline, c, p);
  ASSERT_EQ(r.outcome, RefineOutcome::kRefined) << r.message;
  EXPECT_EQ(r.before.break_points, 2u);
  EXPECT_EQ(r.after.break_points, 2u);
  EXPECT_LT(r.after.length_m, r.before.length_m);
  EXPECT_LT(r.objective_after, r.objective_before);
  EXPECT_GE(r.after.min_clearance_m, p.min_clearance_m) << "clearance below the required margin";
  // End points never move; every vertex stays within the move radius; every segment is clear.
  EXPECT_EQ(r.path.points.front(), b.centreline.points.front());
  EXPECT_EQ(r.path.points.back(), b.centreline.points.back());
  for (std::size_t i = 0; i < r.path.size(); ++i)
    EXPECT_LE((r.path.points[i] - b.centreline.points[i]).norm(), p.move_radius_m + 1e-9);
  for (std::size_t i = 0; i + 1 < r.path.size(); ++i) {
    const Vec3 a = r.path.points[i], e = r.path.points[i + 1];
    const int n = int(std::ceil((e - a).norm() / (0.25 * b.field.resolution())));
    for (int k = 0; k <= n; ++k) EXPECT_GE(b.field.distance(a + (e - a) * (double(k) / n)), kRobotRadius);
  }
  std::printf("bend: length %.3f -> %.3f m, min clearance %.3f -> %.3f m, mean %.3f -> %.3f m, %d iterations\n",
              r.before.length_m, r.after.length_m, r.before.min_clearance_m, r.after.min_clearance_m,
              r.before.mean_clearance_m, r.after.mean_clearance_m, r.optimization.iterations);

  // Deterministic: the same input and seed give the same path, bit for bit.
  const BreakPointRefinement again = refineBreakPoints(b.centreline, c, p);
  ASSERT_EQ(again.path.size(), r.path.size());
  for (std::size_t i = 0; i < r.path.size(); ++i) EXPECT_EQ(again.path.points[i], r.path.points[i]);
}

// The field's proven error bound lets the feasibility scans skip samples a clear one proves
// clear: the same refined path bit for bit, from fewer clearance reads.
TEST(BreakPointRefiner, SkippingProvenClearSamplesChangesNothing) {
  const Bend& b = bend();
  BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  long reads = 0;
  const ClearanceFn field_clearance = fieldClearance(b.field, kRobotRadius);
  const ClearanceFn c = [&](const Vec3& q) {
    ++reads;
    return field_clearance(q);
  };
  const BreakPointRefinement every = refineBreakPoints(b.centreline, c, p);
  const long every_reads = reads;
  reads = 0;
  p.clearance_slack_m = b.field.errorBound();
  const BreakPointRefinement skipping = refineBreakPoints(b.centreline, c, p);
  ASSERT_EQ(every.outcome, RefineOutcome::kRefined) << every.message;
  EXPECT_EQ(skipping.outcome, every.outcome);
  EXPECT_EQ(skipping.message, every.message);
  ASSERT_EQ(skipping.path.size(), every.path.size());
  for (std::size_t i = 0; i < every.path.size(); ++i) EXPECT_EQ(skipping.path.points[i], every.path.points[i]);
  EXPECT_EQ(skipping.objective_after, every.objective_after);
  EXPECT_LT(reads, every_reads);
  std::printf("clearance reads: %ld every sample, %ld skipping proven ones (%.2fx)\n", every_reads, reads,
              double(every_reads) / double(reads));
  // A slack that is not finite is refused.
  p.clearance_slack_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(refineBreakPoints(b.centreline, c, p).outcome, RefineOutcome::kInvalidInput);
}

TEST(BreakPointRefiner, PlanarModeKeepsHeights) {
  const Bend& b = bend();
  BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  p.planar = true;
  const BreakPointRefinement r = refineBreakPoints(b.centreline, fieldClearance(b.field, kRobotRadius), p);
  ASSERT_EQ(r.outcome, RefineOutcome::kRefined) << r.message;
  for (std::size_t i = 0; i < r.path.size(); ++i) EXPECT_EQ(r.path.points[i].z(), b.centreline.points[i].z());
  EXPECT_LT(r.after.length_m, r.before.length_m);
}

TEST(BreakPointRefiner, VertexInRockIsRefused) {
  const Bend& b = bend();
  Polyline corrupted = b.centreline;
  corrupted.points[1].z() -= 5.0;  // a break point pushed into the floor
  const BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  const BreakPointRefinement r = refineBreakPoints(corrupted, fieldClearance(b.field, kRobotRadius), p);
  EXPECT_EQ(r.outcome, RefineOutcome::kInvalidInput);
  EXPECT_NE(r.message.find("input segment 0"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("below the required"), std::string::npos) << r.message;
  ASSERT_EQ(r.path.size(), corrupted.size());
  for (std::size_t i = 0; i < r.path.size(); ++i) EXPECT_EQ(r.path.points[i], corrupted.points[i]);
}

TEST(BreakPointRefiner, BadInputIsRefusedNotCrashed) {
  const Bend& b = bend();
  const ClearanceFn c = fieldClearance(b.field, kRobotRadius);
  BreakPointRefinerParams p;
  Polyline nan_path = b.centreline;
  nan_path.points[2].x() = std::nan("");
  EXPECT_EQ(refineBreakPoints(nan_path, c, p).outcome, RefineOutcome::kInvalidInput);
  EXPECT_EQ(refineBreakPoints(Polyline{{Vec3(1, 0, 1)}}, c, p).outcome, RefineOutcome::kInvalidInput);
  p.move_radius_m = -1;
  const BreakPointRefinement r = refineBreakPoints(b.centreline, c, p);
  EXPECT_EQ(r.outcome, RefineOutcome::kInvalidInput);
  EXPECT_NE(r.message.find("move_radius_m"), std::string::npos) << r.message;
}

TEST(BreakPointRefiner, CallersCheckCanVetoTheResult) {
  const Bend& b = bend();
  const BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  const BreakPointRefinement r =
      refineBreakPoints(b.centreline, fieldClearance(b.field, kRobotRadius), p,
                        [](const Vec3&, const Vec3&) { return invalidArgument("vetoed"); });
  EXPECT_EQ(r.outcome, RefineOutcome::kKeptInput);
  EXPECT_NE(r.message.find("vetoed"), std::string::npos) << r.message;
  EXPECT_EQ(r.path.points, b.centreline.points);
}

// The caller's check refuses only refined segments that start at the start and do not end at the
// first break point as it was: that break point goes back, the other keeps its gain.
TEST(BreakPointRefiner, CallersCheckOnOneSegmentKeepsTheRestRefined) {
  const Bend& b = bend();
  const BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  const std::vector<Vec3>& in = b.centreline.points;
  int calls = 0;
  const BreakPointRefinement r =
      refineBreakPoints(b.centreline, fieldClearance(b.field, kRobotRadius), p, [&](const Vec3& a, const Vec3& e) {
        ++calls;
        return a == in[0] && e != in[1] ? invalidArgument("the first break point may not move") : Status();
      });
  ASSERT_EQ(r.outcome, RefineOutcome::kRefined) << r.message;
  EXPECT_EQ(r.path.points[1], in[1]);
  EXPECT_NE(r.path.points[2], in[2]);
  EXPECT_LT(r.objective_after, r.objective_before);
  EXPECT_NE(r.message.find("1 kept where they were"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("may not move"), std::string::npos) << r.message;
  EXPECT_GT(calls, 1);
}

// Planar mode with a placement: every vertex that moved stands where the placement puts it (its
// height from its x and y), the others keep theirs; no placement = the heights stay.
TEST(BreakPointRefiner, PlacementGivesMovedVerticesTheirHeight) {
  const Bend& b = bend();
  BreakPointRefinerParams p = BreakPointRefinerParams::forField(b.field.resolution(), 0.2);
  p.planar = true;
  // Lifts every vertex it places by a centimetre: a moved vertex is where it says.
  auto floor = [](const Vec3& q) { return Vec3(q.x(), q.y(), q.z() + 0.01); };
  const BreakPointRefinement r =
      refineBreakPoints(b.centreline, fieldClearance(b.field, kRobotRadius), p, {}, floor);
  ASSERT_EQ(r.outcome, RefineOutcome::kRefined) << r.message;
  for (std::size_t i = 0; i < r.path.size(); ++i) {
    const Vec3 q = r.path.points[i];
    if (q.head<2>() == b.centreline.points[i].head<2>()) EXPECT_EQ(q, b.centreline.points[i]);
    else EXPECT_DOUBLE_EQ(q.z(), b.centreline.points[i].z() + 0.01) << "vertex " << i;
  }
  // A placement that finds no floor anywhere: nothing moves.
  const BreakPointRefinement none = refineBreakPoints(
      b.centreline, fieldClearance(b.field, kRobotRadius), p, {},
      [](const Vec3&) { return Vec3::Constant(std::numeric_limits<double>::quiet_NaN()); });
  EXPECT_EQ(none.outcome, RefineOutcome::kKeptInput) << none.message;
  EXPECT_EQ(none.path.points, b.centreline.points);
}

}  // namespace
}  // namespace adit::fusion
