// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// RobotValidity: is the robot clear of rock at a point, along a segment, on the floor? The one
// place that turns a robot shape and the map layer into yes/no answers; OMPL's validity checker,
// motion validator, adit's shortcutting and the final re-validation all call it, so they agree.
//
// Shapes: sphere and capsule read the distance field (capsules stand upright, the field is read
// along their axis); box and cylinder go through CollisionChecker (exact FCL against the rock
// voxels). A box is checked as the upright cylinder it sweeps when it turns about z, so a path is
// valid at any heading. The field is conservative by half a voxel: required field distance is
// radius + safety margin + resolution / 2.
//
// Ground mode: the state's z is the robot's centre, half_height above the floor. The body is
// checked lifted by margin + two voxels so that the floor it stands on (quantised to voxels, one
// voxel higher under part of the footprint on a slope) is not "rock in the way".
//
// Headed (ground mode, box robots): where the turning cylinder does not fit, a pose is still
// valid when the box fits at the heading it moves along (a state: at some heading of 16 over half
// a turn, the box being symmetric), and a break point when the box can turn there from the
// heading of the segment before it to the one after it (the shorter way, modulo half a turn).
// This is how a 0.7 m-wide tracked robot passes a 1.5 m gap its 1.2 m turning circle does not.
#include <cmath>
#include <optional>
#include <vector>

#include "adit/global/global_planner_params.hpp"
#include "adit/map/collision.hpp"
#include "adit/map/distance_field.hpp"
#include "adit/map/occupancy_map.hpp"

namespace adit::global {

class RobotValidity {
 public:
  /// `headed`: check a box robot at its heading where its turning cylinder does not fit (ground
  /// mode only; ignored otherwise).
  RobotValidity(const map::DistanceField& field, const map::CollisionChecker& checker,
                const GlobalPlannerParams& params, bool headed = false);

  /// Field distance needed at the robot's reference point (horizontal radius + margin + res/2).
  double requiredClearance() const { return required_; }
  double halfHeight() const { return half_height_; }
  /// Ground mode: how far above a standing centre the body's clearance is read (0 flying).
  double lift() const { return ground() ? lift_ : 0.0; }
  double step() const { return step_; }
  bool ground() const { return params_.mode == PlanMode::kGround; }
  bool headed() const { return headed_; }

  /// Fly: the body at `c` clears the rock. Ground: additionally c.z is within ground_tolerance_m
  /// of floor + half_height.
  bool stateValid(const map::Vec3& c) const;
  /// Every sample of a-b (step() apart) is a valid state; ground mode also limits the slope.
  bool motionValid(const map::Vec3& a, const map::Vec3& b) const;
  /// Last valid sample fraction along a-b (for OMPL's lastValid); 1 when the whole motion is valid.
  bool motionValid(const map::Vec3& a, const map::Vec3& b, double* last_valid_fraction) const;
  /// Ground mode: the floor slope along the whole path, over slope_baseline_m windows, is within
  /// max_slope_deg (a chain of short segments cannot sneak up a ramp). Always true when flying.
  bool pathSlopeValid(const std::vector<map::Vec3>& path) const;
  /// Headed: the number of break points of `path` where the box cannot turn from the heading of
  /// the segment before to the one after (0 when not headed); `first` gets the first one's index.
  int badTurns(const std::vector<map::Vec3>& path, std::size_t* first = nullptr) const;
  /// Distance from the robot's surface to rock at `c` [m] (ground mode: at the lifted body).
  double clearance(const map::Vec3& c) const;
  /// As clearance(c); headed, the box's at heading `yaw` where that is larger (it always is for
  /// a box inside its turning cylinder).
  double clearance(const map::Vec3& c, double yaw) const;
  /// Top of the floor under `c` (searching down from c.z at most `depth` m), if any.
  std::optional<double> floorBelow(const map::Vec3& c, double depth) const;
  /// Ground mode: `c` moved to half_height above the floor under it (searched from c.z down).
  std::optional<map::Vec3> onFloor(const map::Vec3& c, double depth) const;
  /// Cost of a-b under the clearance-aware objective (length weighted by a clearance penalty).
  double segmentCost(const map::Vec3& a, const map::Vec3& b) const;
  /// Penalty weight at one point: 1 + w * max(0, 1 - extra / preferred).
  double costFactor(const map::Vec3& c) const;

 private:
  // Floor heights along a walk, checked over a sliding baseline.
  class SlopeWindow {
   public:
    explicit SlopeWindow(const RobotValidity& v)
        : v_(v), tan_max_(std::tan(v.params_.max_slope_deg * 3.14159265358979323846 / 180.0)) {}
    bool add(double s, double floor);
    bool steepnessOk(double run, double z0, double z1) const;
    double first() const { return floors_.front().second; }
    double last() const { return floors_.back().second; }

   private:
    const RobotValidity& v_;
    double tan_max_;
    std::vector<std::pair<double, double>> floors_;  // (horizontal distance, floor height)
    std::size_t tail_ = 0;
  };
  bool bodyClear(const map::Vec3& c) const;
  /// `shape` centred at `c`, turned to `yaw` about z, is at least the margin from rock (exact,
  /// through the checker).
  bool shapeClearAt(const map::RobotShape& shape, const map::Vec3& c, double yaw) const;
  /// Where the state's body is checked: on its floor, lifted; nullopt off the floor.
  std::optional<map::Vec3> bodyAt(const map::Vec3& p) const;
  /// The body at `b` (already lifted) is clear turned to `yaw`; NaN yaw: at some heading.
  bool bodyClearHeaded(const map::Vec3& b, double yaw) const;
  /// Floor under p when p is at half-height above it (within the ground tolerance).
  std::optional<double> groundFloor(const map::Vec3& p) const;
  const map::DistanceField* field_;
  const map::CollisionChecker* checker_;
  GlobalPlannerParams params_;
  map::RobotShape checked_;  // the shape the checker sees (box -> its turning cylinder)
  double res_ = 0.1, required_ = 0.0, half_height_ = 0.0, step_ = 0.05, lift_ = 0.0;
  bool headed_ = false;
};

}  // namespace adit::global
