// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Every rock surface point within a radius, written into a buffer the caller owns: what the
/// field-of-view and VFF-style repulsions of the local layer sum over (the DistanceField gives
/// only the nearest rock). A rock voxel is on the surface when one of its 6 neighbours is free;
/// for each such voxel whose cube comes within `radius` of the centre, the query writes the point
/// of the cube nearest to the centre. It never allocates, so the per-period local step may call it.
///
///   std::array<Vec3, 512> buf;
///   RockPointsResult r = rockSurfacePoints(field, robot, 2.0, buf.data(), buf.size());
///   for (std::size_t i = 0; i < r.written; ++i) repel(buf[i]);
///   if (r.truncated) warn();   // more points than the buffer holds

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "adit/map/distance_field.hpp"
#include "adit/map/types.hpp"

namespace adit::map {

struct RockPointsResult {
  std::size_t written = 0;  ///< points written to the buffer
  std::size_t found = 0;    ///< surface points within the radius (> written when truncated)
  bool truncated = false;   ///< the buffer was too small, or the window too large (see below)
};

/// Rock surface points within `radius` of `centre` (distance from the centre to the voxel cube).
/// Order: by voxel, z-major then y then x. The scan visits at most `max_window_voxels` voxels;
/// a larger window (or a non-finite centre or radius) writes nothing and sets truncated.
/// Voxels nearer to the centre than its distance-field clearance are known free and skipped.
RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, Vec3* out,
                                   std::size_t capacity, std::size_t max_window_voxels = 1u << 18) noexcept;

/// A cone about `axis` (unit or zero = no cone) with half opening `half_angle_rad`.
struct ViewCone {
  Vec3 axis = Vec3::Zero();
  double half_angle_rad = 3.14159265358979323846;
};
/// The same, only the points inside the cone (a field of view): voxels outside are not read.
RockPointsResult rockSurfacePoints(const DistanceField& field, const Vec3& centre, double radius, const ViewCone& cone,
                                   Vec3* out, std::size_t capacity,
                                   std::size_t max_window_voxels = 1u << 18) noexcept;

/// A ground robot's view of the rock: a 2-D scan of what it cannot drive into, one nearest point
/// per azimuth bin (as a horizontal laser would see it). A 2.5-D traversability test per voxel
/// column within `radius` (horizontally) of `centre`, the robot standing on a floor at `z_floor`:
/// the column's floor is the highest rock below the climbable height there, z_floor + max_step
/// + half a voxel + s tan(max slope) at horizontal distance s (voxel centres are compared, so a
/// floor one voxel higher, the quantisation of any slope, is never a wall). The column is in the
/// way when
///  - rock stands above its floor within the body's `height` (a rib, a pillar, a low roof),
///  - its floor is more than max_step (at least one voxel: the quantisation of any slope) + half a
///    voxel above or below the next column toward the robot (a step, or a ledge down),
///  - its floor rises or falls faster than the slope allows, measured against the column a metre
///    (or four voxels) nearer the robot, beyond a voxel of quantisation; nearer than that against
///    the robot's own floor, beyond max_step and a voxel, or
///  - it has no floor within a metre below the robot's (a drop).
/// Uses no allocation; visits at most `max_window_voxels` voxel columns (else nothing is written
/// and the result is truncated).
/// The body's underside, for rockInBand: within `reach` of the centre a column whose floor stands
/// more than `clearance` above the floor's plane through the robot's floor (rise per metre
/// grad_x, grad_y) is in the way, however gently it rises: the body standing on that plane meets
/// it (a lump, a rib's foot curving up, each column a voxel above the last, passes every step and
/// slope test between columns).
struct BandBody {
  double grad_x = 0.0, grad_y = 0.0;
  double reach = 0.0;
  double clearance = 0.0;
};
struct BandScan {
  static constexpr int kBins = 24;
  double distance[kBins];  ///< horizontal distance from the centre to the nearest such column's cube; inf: none
  Vec3 point[kBins];       ///< that point (z: the robot's floor)
  bool truncated = false;
};
/// What band scans have read of the field's voxel columns, kept from one scan to the next. Each
/// column is searched up to three times a scan (its own floor, the step against the column next
/// to it, the slope against the one a metre nearer), and a robot moves a voxel or less a period:
/// with this cache each voxel is read once while it stays near the robot, and runs of free
/// voxels are skipped by the field's exact clearance (a voxel that far from rock has free voxels
/// below it). A ring of columns about the robot, each tagged with its key; everything is dropped
/// when the field's generation changes (an update).
///
/// Each column also keeps its answers for the scan's few search tops (the highest rock at or
/// below each), made once while the robot's floor stays on one voxel level, so that a search is a
/// table read; and the floors those answers can give. When every floor the window can give is
/// within a step of a column's own, its step and slope tests cannot fail and are not made; a
/// column that is one such floor at every top, near the robot's own floor and out of the body's
/// reach is never in the way and is passed by unmeasured (most of a roadway's columns).
/// Allocated once by reserve(); scans do not allocate, and one that does not fit reads the field
/// voxel by voxel (the same result: the tests hold the two equal on rugged terrain, pillar fields,
/// the district's roadways and the smallest kerb and ramp that fail).
class BandCache {
 public:
  /// Sizes the cache for scans of up to `radius` on a field of `resolution`, for a robot of
  /// this height, step and slope limit. Allocates; false (and no cache) when that would take
  /// more than 64 MiB or the arguments are not finite and positive.
  bool reserve(double resolution, double radius, double max_step, double slope_tan, double height);
  bool empty() const { return ring_ == 0; }

 private:
  friend void rockInBand(const DistanceField&, const Vec3&, double, double, double, double, double, BandScan&,
                         std::size_t, BandCache*, const BandBody*) noexcept;
  friend struct BandColumns;
  static constexpr int kMaxTops = 16;
  static constexpr std::int8_t kMixed = -128;
  // One cache line: a scan reads every slot of its window once before it starts.
  struct alignas(64) Slot {
    std::int64_t i = 0, j = 0;  // the column's key (x, y), when valid
    std::int64_t k0 = 0;        // key of the lowest voxel its bits hold
    // The table's scan keys: tops t_lo .. t_lo + tops - 1, bottom b_lo (tops = 0: no table).
    std::int64_t t_lo = 0, b_lo = 0;
    std::int8_t tops = 0;
    // The floors its answers can give (relative to b_lo; none when fmin > fmax): an answer below
    // its top (rock at the top of a search is the body's band, never a floor).
    std::int8_t fmin = 1, fmax = 0;
    bool valid = false;
    std::int8_t highest[kMaxTops];  // highest rock key at or below t_lo + n, down to b_lo, minus b_lo; -1: none
  };
  static_assert(sizeof(Slot) == 64, "a slot is one cache line");
  double res_ = 0.0;
  std::int64_t ring_ = 0, words_ = 0;
  std::uint64_t generation_ = 0;
  std::vector<Slot> slots_;
  std::vector<std::uint64_t> known_, rock_;  // words_ per slot: one bit per voxel from k0 up
  // One scan's columns within its radius (offsets in its window), with their tables' one floor
  // (the answer of every top when all are one floor, relative to b_lo; kMixed otherwise) and their
  // nearest point's squared distance: ring_ x ring_ of them at most.
  struct Candidate {
    std::int32_t di = 0, dj = 0;
    std::int8_t uniform = kMixed;
    double q = 0.0;
  };
  std::vector<Candidate> candidates_;
  // floorSlope's sample reaches for the arguments in reach_key_ (half window, slope, step) and
  // reach_n_ x reach_n_ samples; 0: none yet.
  std::vector<double> reach_;
  double reach_key_[3] = {0.0, 0.0, 0.0};
  int reach_n_ = 0;
};

void rockInBand(const DistanceField& field, const Vec3& centre, double radius, double z_floor, double max_step,
                double slope_tan, double height, BandScan& out, std::size_t max_window_columns = 1u << 16,
                BandCache* cache = nullptr, const BandBody* body = nullptr) noexcept;

/// Top of the floor under `p`: searching down from `p` in voxel steps for at most `depth` m, the
/// height of the first rock voxel's top. None when `p` is not free or nothing is within `depth`.
/// A few field reads; no allocation.
std::optional<double> floorBelow(const DistanceField& field, const Vec3& p, double depth) noexcept;

/// The floor's rise per metre along a heading and across it, as a ground vehicle's body settles:
/// the least-squares plane through the floor (floorBelow) at n x n samples over a square of
/// half-side `half_window` centred on `at` (x, y, and z the floor there) and turned to `yaw`.
/// A voxel map quantises a sloping floor into stairs one voxel high; the plane through a body's own
/// ends tilts it by a whole stair on every stair edge (16 degrees for a 0.7 m-wide body on a 0.2 m
/// map), the fit over the window by at most 0.75 res / half_window, a real incline by its slope.
/// Samples with no floor (beyond a rib) or on another level (farther than r * slope_tan + step
/// from the centre's floor at distance r) are left out; with too few left to fix a plane the
/// floor counts as level. No allocation.
struct FloorSlope {
  double along = 0.0;   ///< rise per metre along (cos yaw, sin yaw)
  double across = 0.0;  ///< rise per metre along (-sin yaw, cos yaw), the vehicle's left
  int samples = 0;      ///< samples in the fit
};
/// With a cache (the band scan's, reserved for a radius at least the window's half-diagonal),
/// the same answer from the voxels it holds: the band scan that follows reads the same columns.
FloorSlope floorSlope(const DistanceField& field, const Vec3& at, double yaw, double half_window, double slope_tan,
                      double step, int n = 9, BandCache* cache = nullptr) noexcept;

}  // namespace adit::map
