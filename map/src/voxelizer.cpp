// SPDX-License-Identifier: BSD-3-Clause
// Survey network -> voxels -> OctoMap. Sweeps are done in a sparse bit set first (fast, exact
// voxel-centre tests), then written into the octree once and pruned.
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "adit/map/survey_network.hpp"
#include "voxel_blocks.hpp"

namespace adit::map {

namespace {

using internal::BitVoxelSet;
using internal::centreOf;
using internal::keyOf;

class Sweeper {
 public:
  Sweeper(double res, BitVoxelSet* out) : res_(res), inv_(1.0 / res), out_(out) {}

  // Section swept along the floor segment a->b, perpendicular to it: the lateral axis is
  // horizontal, the section's "up" axis is perpendicular to the centreline in its vertical
  // plane, so an inclined roadway keeps its full clearance measured square to the floor (a
  // vertical section would leave h cos(theta): 0.46 m of a 3 m section at 70 degrees).
  void segment(const Vec3& a, const Vec3& b, const CrossSection& s) {
    const Vec3 d = b - a;
    const double len = d.norm();
    const double hlen = d.head<2>().norm();
    const Vec3 dir = d / len;
    const Eigen::Vector2d t = d.head<2>() / hlen, n(-t.y(), t.x());
    const double sin_t = dir.z(), cos_t = hlen / len;
    const Vec3 up(-sin_t * t.x(), -sin_t * t.y(), cos_t);
    const double hw = 0.5 * s.maxWidth(), h = s.height();
    // Horizontal footprint along t: the roof end caps lean back by h sin(theta).
    const double lean = -h * sin_t;
    const double s_lo = std::min(0.0, lean), s_hi = hlen + std::max(0.0, lean);
    double xmin = 1e300, xmax = -1e300;
    for (double sa : {s_lo, s_hi})
      for (double su : {-hw, hw}) {
        const double x = a.x() + sa * t.x() + su * n.x();
        xmin = std::min(xmin, x);
        xmax = std::max(xmax, x);
      }
    for (int kx = keyOf(xmin, inv_); kx <= keyOf(xmax, inv_); ++kx) {
      const double xc = centreOf(kx, res_);
      double ylo = -1e300, yhi = 1e300;
      if (!slab(xc - a.x(), t.x(), t.y(), s_lo, s_hi, a.y(), &ylo, &yhi)) continue;
      if (!slab(xc - a.x(), n.x(), n.y(), -hw, hw, a.y(), &ylo, &yhi)) continue;
      for (int ky = keyOf(ylo, inv_); ky <= keyOf(yhi, inv_); ++ky) {
        const double yc = centreOf(ky, res_);
        const Eigen::Vector2d p(xc - a.x(), yc - a.y());
        const double u = p.dot(n);
        if (std::abs(u) > hw) continue;
        // along(z) and v(z) are linear in z; v's slope is cos(theta) > 0.
        const double along0 = p.x() * dir.x() + p.y() * dir.y(), v0 = p.x() * up.x() + p.y() * up.y();
        double zlo = a.z() - v0 / cos_t, zhi = a.z() + (h - v0) / cos_t;
        if (std::abs(sin_t) > 1e-12) {
          double z1 = a.z() - along0 / sin_t, z2 = a.z() + (len - along0) / sin_t;
          if (z1 > z2) std::swap(z1, z2);
          zlo = std::max(zlo, z1);
          zhi = std::min(zhi, z2);
        } else if (along0 < 0 || along0 > len) {
          continue;
        }
        for (int kz = keyOf(zlo, inv_); kz <= keyOf(zhi, inv_); ++kz) {
          const double dz = centreOf(kz, res_) - a.z();
          const double along = along0 + dz * sin_t, v = v0 + dz * cos_t;
          if (along >= 0 && along <= len && v >= 0 && v <= h && std::abs(u) <= s.halfWidthAt(v)) out_->set(kx, ky, kz);
        }
      }
    }
  }

  // Section revolved about the vertical through a station: fills the wedge at a bend and rounds
  // the corner where roadways meet.
  void revolve(const Vec3& p, const CrossSection& s) {
    const double hw = 0.5 * s.maxWidth(), h = s.height();
    for (int kx = keyOf(p.x() - hw, inv_); kx <= keyOf(p.x() + hw, inv_); ++kx)
      for (int ky = keyOf(p.y() - hw, inv_); ky <= keyOf(p.y() + hw, inv_); ++ky) {
        const double r = std::hypot(centreOf(kx, res_) - p.x(), centreOf(ky, res_) - p.y());
        if (r > hw) continue;
        column(kx, ky, p.z(), h, [&](double v) { return r <= s.halfWidthAt(v); });
      }
  }

 private:
  // Intersects [lo, hi] with the y values where c0 + cy*(y - y0) lies in [a, b], c0 = cx*dx.
  static bool slab(double dx, double cx, double cy, double a, double b, double y0, double* lo, double* hi) {
    const double c0 = cx * dx;
    if (std::abs(cy) < 1e-12) return c0 >= a - 1e-9 && c0 <= b + 1e-9;
    double y1 = y0 + (a - c0) / cy, y2 = y0 + (b - c0) / cy;
    if (y1 > y2) std::swap(y1, y2);
    *lo = std::max(*lo, y1);
    *hi = std::min(*hi, y2);
    return *lo <= *hi;
  }

  template <class Inside>
  void column(int kx, int ky, double floor_z, double h, Inside&& inside) {
    for (int kz = keyOf(floor_z, inv_); kz <= keyOf(floor_z + h, inv_); ++kz) {
      const double v = centreOf(kz, res_) - floor_z;
      if (v >= 0 && v <= h && inside(v)) out_->set(kx, ky, kz);
    }
  }

  double res_, inv_;
  BitVoxelSet* out_;
};

// One step of 26-neighbourhood dilation (x, then y, then z), creating blocks as the set grows.
BitVoxelSet dilateOnce(const BitVoxelSet& in) {
  using internal::kBlockBits;
  using internal::kBlockMask;
  using internal::kBlockSize;
  auto pass = [](const BitVoxelSet& src, int axis) {
    BitVoxelSet dst;
    for (std::size_t i = 0; i < src.blockCount(); ++i) {
      const auto& c = src.blockCoord(i);
      const auto& blk = src.blockAt(i);
      for (int r = 0; r < kBlockSize * kBlockSize; ++r) {
        const std::uint16_t bits = blk[r];
        if (!bits) continue;
        const int y = (c[1] << kBlockBits) + (r & kBlockMask), z = (c[2] << kBlockBits) + (r >> kBlockBits);
        if (axis == 0) {
          dst.row(c[0], y, z) |= std::uint16_t(bits | (bits << 1) | (bits >> 1));
          if (bits & 1u) dst.row(c[0] - 1, y, z) |= std::uint16_t(1u << kBlockMask);
          if (bits & (1u << kBlockMask)) dst.row(c[0] + 1, y, z) |= 1u;
        } else {
          dst.row(c[0], y, z) |= bits;
          for (int d : {-1, 1}) {
            if (axis == 1) dst.row(c[0], y + d, z) |= bits;
            else dst.row(c[0], y, z + d) |= bits;
          }
        }
      }
    }
    return dst;
  };
  return pass(pass(pass(in, 0), 1), 2);
}

}  // namespace

StatusOr<OccupancyMap> voxelize(const SurveyNetwork& net, const VoxelizeOptions& options) {
  ADIT_RETURN_IF_ERROR(net.validate());
  if (net.estimatedVoxels() > options.max_voxels) {
    std::ostringstream os;
    os << "the survey network would need about " << net.estimatedVoxels() << " voxels at resolution "
       << net.resolution_m << " m (limit " << options.max_voxels << "); use a coarser resolution";
    return outOfRange(os.str());
  }
  auto progress = [&](const char* stage, double f) { if (options.progress) options.progress(stage, f); };
  const double res = net.resolution_m;

  BitVoxelSet free;
  Sweeper sweeper(res, &free);
  std::map<std::string, int> endpoint_use;  // how many roadway ends meet at each station
  for (const SurveyRoadway& road : net.roadways) {
    ++endpoint_use[road.stations.front()];
    ++endpoint_use[road.stations.back()];
  }
  for (std::size_t i = 0; i < net.roadways.size(); ++i) {
    const SurveyRoadway& road = net.roadways[i];
    const CrossSection& s = net.sections.at(road.section);
    for (std::size_t k = 1; k < road.stations.size(); ++k)
      sweeper.segment(net.stations.at(road.stations[k - 1]), net.stations.at(road.stations[k]), s);
    for (std::size_t k = 0; k < road.stations.size(); ++k) {
      const bool interior = k > 0 && k + 1 < road.stations.size();
      if (interior || endpoint_use[road.stations[k]] > 1) sweeper.revolve(net.stations.at(road.stations[k]), s);
    }
    progress("sweeping roadways", double(i + 1) / double(net.roadways.size()));
  }

  // Rock shell: dilate the free set by the shell thickness (cube element), minus the free set.
  BitVoxelSet grown = free;
  const int shell_steps = int(std::ceil(net.rock_shell_m / res - 1e-9));
  for (int i = 0; i < shell_steps; ++i) {
    grown = dilateOnce(grown);
    progress("rock shell", double(i + 1) / shell_steps);
  }

  auto tree = std::make_shared<octomap::OcTree>(res);
  const float free_value = tree->getClampingThresMinLog(), rock_value = tree->getClampingThresMaxLog();
  const double total_blocks = double(grown.blockCount());
  for (std::size_t i = 0; i < grown.blockCount(); ++i) {
    const auto& c = grown.blockCoord(i);
    const auto& blk = grown.blockAt(i);
    const BitVoxelSet::Block* fblk = free.find(c[0], c[1], c[2]);
    for (int r = 0; r < internal::kBlockSize * internal::kBlockSize; ++r) {
      unsigned bits = blk[r];
      const unsigned fbits = fblk ? (*fblk)[r] : 0u;
      while (bits) {
        const int bx = __builtin_ctz(bits);
        bits &= bits - 1;
        const octomap::OcTreeKey key(
            octomap::key_type((c[0] << internal::kBlockBits) + bx),
            octomap::key_type((c[1] << internal::kBlockBits) + (r & internal::kBlockMask)),
            octomap::key_type((c[2] << internal::kBlockBits) + (r >> internal::kBlockBits)));
        tree->setNodeValue(key, ((fbits >> bx) & 1u) ? free_value : rock_value, /*lazy_eval=*/true);
      }
    }
    if ((i & 255) == 0 || i + 1 == grown.blockCount()) progress("building octree", double(i + 1) / total_blocks);
  }
  // Its own stage: on the district it is a third of the load, and it used to be unlabelled.
  progress(kPruneStage, 0.0);
  tree->updateInnerOccupancy();
  tree->prune();
  StatusOr<OccupancyMap> map = OccupancyMap::create(std::move(tree), options.unknown_policy);
  progress(kPruneStage, 1.0);
  return map;
}

}  // namespace adit::map
