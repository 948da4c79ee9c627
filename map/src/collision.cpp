// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/collision.hpp"

#include <fcl/geometry/octree/octree.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <type_traits>
#include <variant>
#include <vector>

#include "fcl_adapter.hpp"
#include "shape_geometry.hpp"
#include "voxel_blocks.hpp"

namespace adit::map {
namespace {

using namespace fclx;  // NOLINT(google-build-using-namespace): the checker is made of these
using namespace geom;  // NOLINT(google-build-using-namespace)

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kHalfSqrt3 = 0.86602540378443864676;
// A search window beyond this many voxels (16 MB of scratch) means a robot absurdly large for
// the map's resolution; the query is refused like invalid input rather than stalling the caller.
constexpr std::int64_t kMaxWindowVoxels = std::int64_t{1} << 24;
// Slack on bounds that are mathematically tight but computed in floating point.
constexpr double kBoundSlack = 1e-9;

struct Candidate {
  double lower_bound;
  Vec3 centre;
};

// Scratch buffers reused across queries of a thread (the hot path does not allocate).
struct Scratch {
  std::vector<std::uint8_t> rock;
  std::vector<Candidate> candidates;
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

}  // namespace

Status validateQuery(const RobotShape& shape, const Eigen::Isometry3d& pose) {
  switch (shape.type) {
    case ShapeType::kSphere: case ShapeType::kBox: case ShapeType::kCylinder: case ShapeType::kCapsule: break;
    default: return invalidArgument("shape type " + std::to_string(int(shape.type)) + " is not a ShapeType");
  }
  ADIT_RETURN_IF_ERROR(shape.validate());
  if (!pose.matrix().allFinite()) {
    std::ostringstream os;
    os << "pose is not finite: translation (" << pose.translation().transpose() << ")";
    return invalidArgument(os.str());
  }
  const Eigen::Matrix3d r = pose.linear();
  const double orth = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth > 1e-6 || r.determinant() < 0.0) {
    std::ostringstream os;
    os << "pose rotation is not a rotation (|R^T R - I| = " << orth << ", det = " << r.determinant() << ")";
    return invalidArgument(os.str());
  }
  return {};
}

ShapeDistance shapeDistance(const RobotShape& a, const Eigen::Isometry3d& pose_a,
                            const RobotShape& b, const Eigen::Isometry3d& pose_b) {
  if (!validateQuery(a, pose_a).ok() || !validateQuery(b, pose_b).ok()) return invalidResult();
  const FclShape ga(a), gb(b);
  return guarded([&] { return fclPairDistance(ga.get(), pose_a, gb.get(), pose_b); });
}

ShapeDistance obstacleDistance(const RobotShape& robot, const Eigen::Isometry3d& pose,
                               const MovingObstacle& ob, double t_s) {
  if (!std::isfinite(t_s)) return invalidResult();
  Eigen::Isometry3d ob_pose = Eigen::Isometry3d::Identity();
  ob_pose.translation() = ob.positionAt(t_s);
  return shapeDistance(robot, pose, ob.shape, ob_pose);
}

// ---- CollisionChecker ----------------------------------------------------------------------

StatusOr<CollisionChecker> CollisionChecker::create(const OccupancyMap& map, const DistanceField& field) {
  if (std::abs(map.resolution() - field.resolution()) > 1e-9 * map.resolution()) {
    std::ostringstream os;
    os << "CollisionChecker: distance field resolution " << field.resolution()
       << " m differs from the map's " << map.resolution() << " m (build the field from this map)";
    return invalidArgument(os.str());
  }
  return CollisionChecker(map, field);
}

double CollisionChecker::resolution() const { return field_->resolution(); }

namespace {

// Collects the rock voxels of `window` that have a free 6-neighbour and a lower bound <= `reach`.
// Only those can hold the nearest rock point of a shape whose origin is free: the nearest point
// lies on the boundary of the rock, and every boundary point belongs to a rock cube that shares a
// face with a free one (walk the 2x2x2 voxels around the point from a free one to a rock one).
// The same argument covers penetration: a shape with a free origin that overlaps rock crosses
// that boundary. The field is read lazily, only for voxels within reach and their neighbours, and
// not at all inside the ball of radius `clear_lb` around `origin`, which is known to be free.
// Returns false when the window is too large.
bool collectSurfaceRock(const DistanceField& field, const Aabb& window, const CubeLowerBound& bound,
                        double reach, const Vec3& origin, double clear_lb, std::vector<Candidate>& out,
                        std::vector<std::uint8_t>& state) {
  const double res = field.resolution(), inv = 1.0 / res, half = 0.5 * res;
  if (!((window.size() * inv).array() < 1e6).all()) return false;  // also NaN and infinity
  std::int64_t lo[3], n[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::int64_t(std::floor(window.min[a] * inv)) - 1;  // grown by one voxel
    n[a] = std::int64_t(std::floor(window.max[a] * inv)) + 1 - lo[a] + 1;
  }
  if (n[0] * n[1] * n[2] > kMaxWindowVoxels) return false;
  const std::int64_t sy = n[0], sz = n[0] * n[1];
  // Voxels are read as the search below asks for them (inside the known-free ball it asks for
  // none), but a tile's row at a time: its neighbours along x are asked for next, and one tile
  // lookup serves them all.
  constexpr std::uint8_t kUnread = 2;
  constexpr std::int64_t kFieldTileEdge = std::int64_t{1} << internal::kFieldTileBits;
  state.assign(std::size_t(n[0] * n[1] * n[2]), kUnread);
  auto centre = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return Vec3((Vec3(double(lo[0] + i), double(lo[1] + j), double(lo[2] + k)).array() + 0.5) * res);
  };
  auto isRock = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    std::uint8_t* s = &state[std::size_t(i + sy * j + sz * k)];
    if (*s == kUnread) {
      const std::int64_t first = std::max<std::int64_t>(0, i - ((lo[0] + i) & (kFieldTileEdge - 1)));
      const std::int64_t at[3] = {lo[0] + first, lo[1] + j, lo[2] + k};
      const std::int64_t len[3] = {std::min<std::int64_t>(n[0], first + kFieldTileEdge) - first, 1, 1};
      field.freeVoxels(at, len, s - (i - first));
    }
    return *s == 0;
  };
  // Per x-row, only the voxels in the shell between the known-free ball (cube distance from the
  // origin < clear_lb) and the ball beyond which the bounding sphere is out of reach (cube
  // distance > boundingRadius() + reach) are visited; the per-voxel tests would reject the rest.
  // The row limits err outwards by kBoundSlack, so rounding only ever visits a voxel more.
  const double outer = bound.radius() + reach;
  auto axisGap = [half](double c, double o) { return std::max(std::abs(c - o) - half, 0.0); };
  auto firstAtOrAbove = [&](double x) { return std::int64_t(std::ceil(x * inv - 0.5)) - lo[0]; };
  auto lastAtOrBelow = [&](double x) { return std::int64_t(std::floor(x * inv - 0.5)) - lo[0]; };
  out.clear();
  for (std::int64_t k = 1; k + 1 < n[2]; ++k) {
    const double gz = axisGap((double(lo[2] + k) + 0.5) * res, origin.z());
    for (std::int64_t j = 1; j + 1 < n[1]; ++j) {
      const double gy = axisGap((double(lo[1] + j) + 0.5) * res, origin.y());
      const double rem_outer = outer * outer - gy * gy - gz * gz;
      if (rem_outer < -kBoundSlack) continue;
      const double w_outer = std::sqrt(std::max(rem_outer, 0.0)) + half + kBoundSlack;
      const std::int64_t i_lo = std::max<std::int64_t>(1, firstAtOrAbove(origin.x() - w_outer));
      const std::int64_t i_hi = std::min<std::int64_t>(n[0] - 2, lastAtOrBelow(origin.x() + w_outer));
      // Free voxels: |cx - ox| < w_inner; skipped only when clearly inside.
      const double rem_inner = clear_lb * clear_lb - gy * gy - gz * gz;
      std::int64_t skip_lo = 1, skip_hi = 0;  // empty
      if (clear_lb > 0.0 && rem_inner > 0.0) {
        const double w_inner = std::sqrt(rem_inner) + half - kBoundSlack;
        skip_lo = firstAtOrAbove(origin.x() - w_inner) + 1;
        skip_hi = lastAtOrBelow(origin.x() + w_inner) - 1;
      }
      for (std::int64_t i = i_lo; i <= i_hi; ++i) {
        if (i == skip_lo && skip_lo <= skip_hi) {
          i = skip_hi;
          continue;
        }
        const Vec3 c = centre(i, j, k);
        if (bound.coarseExceeds(c, reach) || !isRock(i, j, k)) continue;
        if (isRock(i - 1, j, k) && isRock(i + 1, j, k) && isRock(i, j - 1, k) && isRock(i, j + 1, k) &&
            isRock(i, j, k - 1) && isRock(i, j, k + 1))
          continue;  // interior rock
        const double lb = bound(c);
        if (lb <= reach) out.push_back({lb, c});
      }
    }
  }
  return true;
}

// Lower bound on the distance from `p` to any rock cube, from the field's feature transform:
// the voxel centre v of p is at least |v - s| from every rock centre (s = its nearest rock voxel),
// and a cube reaches at most sqrt(3)/2 edge from its centre. -inf when the field has no site.
double clearanceLowerBound(const DistanceField& field, const Vec3& p) {
  const double res = field.resolution(), inv = 1.0 / res;  // the field's own key formula
  const Vec3 site = field.nearestRockVoxel(p);
  if (!allFinite(site)) return -kInf;
  const Vec3 v = ((p * inv).array().floor() + 0.5) * res;
  return (v - site).norm() - kHalfSqrt3 * res - (p - v).norm();
}

// The same bound from the 8 voxel centres c_i around p, which loses almost nothing where the
// clearance varies slowly (the bound above loses |p - v|, up to sqrt(3)/2 voxel): with the
// trilinear weights w_i of p among them (they sum to 1 and average the c_i to p), every point r
// has |p - r|^2 = sum w_i |c_i - r|^2 - sum w_i |c_i - p|^2, and a rock centre r is at least the
// stored clearance D_i from each c_i. Less a rounding margin; -inf where it proves nothing.
// Callers take the better of the two.
double eightVoxelClearanceLowerBound(const DistanceField& field, const Vec3& p) {
  if (!allFinite(p)) return -kInf;
  const double res = field.resolution(), inv = 1.0 / res;
  const Vec3 u = p * inv - Vec3::Constant(0.5);
  const Vec3 b = u.array().floor();
  const Vec3 f = u - b;
  double sum = 0.0, spread = 0.0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner(double(c & 1), double((c >> 1) & 1), double(c >> 2));
    const Vec3 centre = (b + corner + Vec3::Constant(0.5)) * res;
    const double w = ((c & 1) ? f.x() : 1.0 - f.x()) * ((c & 2) ? f.y() : 1.0 - f.y()) * ((c & 4) ? f.z() : 1.0 - f.z());
    const double d = field.voxelClearance(centre);  // 0 in rock, one voxel where no site is known
    sum += w * d * d;
    spread += w * (centre - p).squaredNorm();
  }
  const double l2 = sum - spread;
  if (!(l2 > 0.0)) return -kInf;
  return std::sqrt(l2) * (1.0 - 1e-12) - kHalfSqrt3 * res - 1e-9 * res;
}

// A lower bound on the distance from the posed shape to rock from a few field reads, for the
// queries that only ask whether the shape clears rock by some margin. The bounding ball of a body
// that stands over its floor (a ground robot, the global planner's checks of it) reaches the
// floor, so the bound at the origin decides nothing there and every such query scanned the
// surface rock of its whole box. Instead the shape's local box is split, where needed, into cells
// whose balls (about the cell's centre, radius half its diagonal) cover it: a cell is settled when
// clearanceLowerBound(centre) - radius exceeds `need`, left out when it misses the shape, and
// otherwise halved along its edges longer than about 1.5 voxels, down to cells of that size. A
// body far from rock is settled by its first ball, one over a floor by a few dozen small ones
// along its underside. Returns a value > `need` when every cell is settled (a lower bound on the
// distance), else the first cell's that was not (the caller then does the exact search).
double coveredLowerBound(const DistanceField& field, const RobotShape& shape, const Eigen::Isometry3d& pose,
                         double need) {
  Vec3 half;
  switch (shape.type) {
    case ShapeType::kSphere: return -kInf;  // the bound at the origin is already the best one
    case ShapeType::kBox: half = 0.5 * shape.size; break;
    case ShapeType::kCylinder: half = Vec3(shape.radius, shape.radius, 0.5 * shape.length); break;
    case ShapeType::kCapsule: half = Vec3(shape.radius, shape.radius, 0.5 * shape.length + shape.radius); break;
    default: return -kInf;
  }
  // Cells of 1.5 voxels have balls of about 1.3 voxels, which a 0.2 m map's roadway floor clears
  // under a body lifted a safety margin above it; smaller cells would only cost reads.
  const double smallest = 1.5 * field.resolution();
  const double half_len = 0.5 * shape.length;
  struct Cell {
    Vec3 lo, hi;
  };
  // Depth-first, so the stack holds at most seven cells per level of splitting (70 levels here).
  // A shape huge for the map's resolution could settle cells for a long time: past kBudget cells
  // the exact search decides, as it would without this bound (it has limits of its own).
  constexpr int kStack = 512, kBudget = 4096;
  Cell stack[kStack];
  int top = 0, cells = 0;
  stack[top++] = {-half, half};
  double least = kInf;
  while (top > 0) {
    if (++cells > kBudget) return -kInf;
    const Cell c = stack[--top];
    if (shape.type != ShapeType::kBox) {
      // The cell's gap to the shape's axis (cylinder: the z axis; capsule: its segment).
      const double gx = std::max({c.lo.x(), -c.hi.x(), 0.0}), gy = std::max({c.lo.y(), -c.hi.y(), 0.0});
      const double gz =
          shape.type == ShapeType::kCapsule ? std::max({c.lo.z() - half_len, -half_len - c.hi.z(), 0.0}) : 0.0;
      if (gx * gx + gy * gy + gz * gz > shape.radius * shape.radius) continue;  // misses the shape
    }
    const Vec3 size = c.hi - c.lo;
    const double lb = clearanceLowerBound(field, pose * (0.5 * (c.lo + c.hi))) - 0.5 * size.norm();
    if (lb > need) {
      least = std::min(least, lb);
      continue;
    }
    bool split[3];
    int parts = 1;
    for (int a = 0; a < 3; ++a) {
      split[a] = size[a] > smallest;
      parts *= split[a] ? 2 : 1;
    }
    if (parts == 1 || top + parts > kStack) return lb;
    const Vec3 mid = 0.5 * (c.lo + c.hi);
    for (int m = 0; m < 8; ++m) {
      if (((m & 1) && !split[0]) || ((m & 2) && !split[1]) || ((m & 4) && !split[2])) continue;
      Cell child = c;
      for (int a = 0; a < 3; ++a) {
        if (!split[a]) continue;
        if (m & (1 << a)) child.lo[a] = mid[a];
        else child.hi[a] = mid[a];
      }
      stack[top++] = child;
    }
  }
  return least;
}

bool inCollisionImpl(const DistanceField& field, const RobotShape& shape, const Eigen::Isometry3d& pose) {
  if (!validateQuery(shape, pose).ok()) return true;
  const Vec3 origin = pose.translation();
  if (!field.isFree(origin)) return true;
  // The bounding ball is clear of rock: no FCL needed.
  const double clearance_lb = clearanceLowerBound(field, origin);
  if (clearance_lb > shape.boundingRadius()) return false;
  if (coveredLowerBound(field, shape, pose, 0.0) > 0.0) return false;

  const Aabb box = shapeAabb(shape, pose);
  const CubeLowerBound bound(shape, pose, box, field.resolution());
  Scratch& s = scratch();
  if (!collectSurfaceRock(field, box, bound, 0.0, origin, clearance_lb, s.candidates, s.rock)) return true;
  const FclShape robot(shape);
  fcl::Boxd cube(field.resolution(), field.resolution(), field.resolution());
  Eigen::Isometry3d cube_pose = Eigen::Isometry3d::Identity();
  for (const Candidate& c : s.candidates) {
    cube_pose.translation() = c.centre;
    if (fclCollide(robot.get(), pose, &cube, cube_pose)) return true;
  }
  return false;
}

ShapeDistance distanceImpl(const DistanceField& field, const RobotShape& shape, const Eigen::Isometry3d& pose,
                           double max_distance_m) {
  if (std::isnan(max_distance_m) || !validateQuery(shape, pose).ok()) return invalidResult();
  const double max_d = std::max(max_distance_m, 0.0);
  const Vec3 origin = pose.translation();
  if (!field.isFree(origin)) return collisionAt(origin, 0);

  // 1. Far from rock: a lower bound from the field alone (one read settles most queries; the
  // eight around the origin settle more, and narrow the search of step 4).
  const double radius = shape.boundingRadius();
  double clearance_lb = clearanceLowerBound(field, origin);
  if (!(clearance_lb - radius > max_d))
    clearance_lb = std::max(clearance_lb, eightVoxelClearanceLowerBound(field, origin));
  if (clearance_lb - radius > max_d) {
    ShapeDistance r;
    r.distance_m = clearance_lb - radius;
    r.exact = false;
    return r;
  }
  // The same from the balls that cover the shape: what the search below would end with when it
  // finds nothing within max_d.
  if (std::isfinite(max_d) && coveredLowerBound(field, shape, pose, max_d) > max_d) {
    ShapeDistance r;
    r.distance_m = max_d;
    r.exact = false;
    return r;
  }

  // 2. How far the search must look. The robot holds the ball of its inscribed radius around the
  // origin, and the field's distance is that of a real rock cube, so the true distance is at
  // most clearance - inscribed radius: nothing beyond can be the nearest.
  const DistanceSample at_origin = field.query(origin);
  double reach = max_d;
  if (!at_origin.in_rock)
    reach = std::min(reach, std::max(at_origin.distance - inscribedRadius(shape), 0.0) + kBoundSlack);

  // 3. Seeds: FCL against the field's nearest rock voxel of the origin and of the ends of the
  // shape's long axis. Any rock voxel bounds the distance from above, and a close one shrinks the
  // window of step 4 far more than it costs.
  const FclShape robot(shape);
  const fcl::Boxd cube(field.resolution(), field.resolution(), field.resolution());
  Eigen::Isometry3d cube_pose = Eigen::Isometry3d::Identity();
  ShapeDistance best;
  best.distance_m = kInf;
  int checked = 0;
  Vec3 seeds[3];
  int seed_count = 0;
  auto evaluate = [&](const Vec3& centre) {
    cube_pose.translation() = centre;
    const ShapeDistance d = fclPairDistance(robot.get(), pose, &cube, cube_pose);
    checked += d.candidates_checked;
    if (d.distance_m < best.distance_m || d.collision) best = d;
    return d.collision;
  };
  const SeedPoints seed_points = seedPoints(shape, pose);
  for (int i = 0; i < seed_points.count; ++i) {
    const Vec3& p = seed_points.points[i];
    const Vec3 site = field.nearestRockVoxel(p);
    if (!allFinite(site)) {
      // p lies inside the robot: in rock means overlap.
      if (!field.isFree(p)) return collisionAt(p, checked);
      continue;
    }
    if (std::find(seeds, seeds + seed_count, site) != seeds + seed_count) continue;
    seeds[seed_count++] = site;
    if (evaluate(site)) return collisionAt(best.point_on_robot, checked);
  }
  reach = std::min(reach, best.distance_m + kBoundSlack);
  if (!std::isfinite(reach)) return invalidResult();  // field inconsistent and no limit given

  // 4. Branch and bound over the surface rock voxels in the robot's box grown by `reach`.
  const Aabb box = shapeAabb(shape, pose);
  const CubeLowerBound bound(shape, pose, box, field.resolution());
  Scratch& s = scratch();
  if (!collectSurfaceRock(field, box.inflated(reach), bound, reach, origin, clearance_lb, s.candidates, s.rock))
    return invalidResult();
  auto by_bound = [](const Candidate& a, const Candidate& b) { return a.lower_bound > b.lower_bound; };
  std::make_heap(s.candidates.begin(), s.candidates.end(), by_bound);
  for (auto end = s.candidates.end(); end != s.candidates.begin(); --end) {
    std::pop_heap(s.candidates.begin(), end, by_bound);
    const Candidate& c = *(end - 1);
    if (c.lower_bound >= best.distance_m || best.distance_m <= 0.0) break;  // touching: none nearer
    if (std::find(seeds, seeds + seed_count, c.centre) != seeds + seed_count) continue;
    if (evaluate(c.centre)) return collisionAt(best.point_on_robot, checked);
  }
  best.candidates_checked = checked;
  if (best.distance_m <= max_d) return best;
  // Every unchecked voxel is farther than `reach` (<= max_d) or than `best` (> max_d).
  ShapeDistance r;
  r.distance_m = max_d;
  r.exact = false;
  r.candidates_checked = checked;
  return r;
}

}  // namespace

double CollisionChecker::clearanceLowerBound(const Vec3& p) const {
  return std::max(adit::map::clearanceLowerBound(*field_, p), eightVoxelClearanceLowerBound(*field_, p));
}

bool CollisionChecker::inCollision(const RobotShape& shape, const Eigen::Isometry3d& pose) const {
  return guardedCollide([&] { return inCollisionImpl(*field_, shape, pose); });
}

ShapeDistance CollisionChecker::distance(const RobotShape& shape, const Eigen::Isometry3d& pose,
                                         double max_distance_m) const {
  return guarded([&] { return distanceImpl(*field_, shape, pose, max_distance_m); });
}

// ---- FclOctreeDistance -----------------------------------------------------------------------

struct FclOctreeDistance::Impl {
  explicit Impl(std::shared_ptr<const octomap::OcTree> t) : tree(std::move(t)), octree(tree) {}
  std::shared_ptr<const octomap::OcTree> tree;
  fcl::OcTreed octree;
};

FclOctreeDistance::FclOctreeDistance(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
FclOctreeDistance::FclOctreeDistance(const FclOctreeDistance&) = default;
FclOctreeDistance& FclOctreeDistance::operator=(const FclOctreeDistance&) = default;
FclOctreeDistance::FclOctreeDistance(FclOctreeDistance&&) noexcept = default;
FclOctreeDistance& FclOctreeDistance::operator=(FclOctreeDistance&&) noexcept = default;
FclOctreeDistance::~FclOctreeDistance() = default;

StatusOr<FclOctreeDistance> FclOctreeDistance::create(const OccupancyMap& map) {
  std::shared_ptr<const octomap::OcTree> tree = map.sharedOctree();
  if (!tree) return failedPrecondition("FclOctreeDistance: the map has no octree");
  return FclOctreeDistance(std::make_shared<const Impl>(std::move(tree)));
}

namespace {

ShapeDistance octreeDistance(const fcl::CollisionGeometryd* robot, const Eigen::Isometry3d& pose,
                             const fcl::OcTreed& octree) {
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  fcl::DistanceRequestd request(/*enable_nearest_points=*/true);
  fcl::DistanceResultd result;
  fcl::distance(robot, pose, &octree, identity, request, result);

  ShapeDistance out;
  if (result.min_distance == std::numeric_limits<double>::max()) {
    out.distance_m = kInf;  // not a single occupied node
    return out;
  }
  if (result.min_distance <= 0.0) {
    // -1 on overlap: ask fcl::collide (which also sees occupied nodes only).
    fcl::CollisionRequestd creq(/*num_max_contacts=*/1, /*enable_contact=*/true);
    fcl::CollisionResultd cres;
    fcl::collide(robot, pose, &octree, identity, creq, cres);
    if (cres.isCollision()) {
      out.collision = true;
      out.point_on_robot = out.point_on_obstacle =
          cres.numContacts() > 0 ? cres.getContact(0).pos : pose.translation();
      return out;
    }
  }
  out.distance_m = std::max(result.min_distance, 0.0);
  // FCL 0.7's shape-octree distance records the octree as o1 and its point first, whatever the
  // argument order; follow result.o1 so that a fixed FCL keeps working.
  const bool swapped = result.o1 != robot;
  out.point_on_robot = result.nearest_points[swapped ? 1 : 0];
  out.point_on_obstacle = result.nearest_points[swapped ? 0 : 1];
  return out;
}

}  // namespace

ShapeDistance FclOctreeDistance::distance(const RobotShape& shape, const Eigen::Isometry3d& pose) const {
  if (!validateQuery(shape, pose).ok()) return invalidResult();
  const FclShape robot(shape);
  return guarded([&] { return octreeDistance(robot.get(), pose, impl_->octree); });
}

bool FclOctreeDistance::inCollision(const RobotShape& shape, const Eigen::Isometry3d& pose) const {
  if (!validateQuery(shape, pose).ok()) return true;
  const FclShape robot(shape);
  return guardedCollide([&] { return fclCollide(robot.get(), pose, &impl_->octree, Eigen::Isometry3d::Identity()); });
}

}  // namespace adit::map
