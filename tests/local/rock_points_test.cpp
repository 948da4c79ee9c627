// SPDX-License-Identifier: BSD-3-Clause
// map::rockSurfacePoints against a brute-force scan of every voxel in the window.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "adit/map/distance_field.hpp"
#include "adit/map/rock_points.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::map {
namespace {

std::vector<Vec3> bruteForce(const DistanceField& f, const Vec3& c, double radius) {
  const double res = f.resolution(), half = 0.5 * res;
  std::vector<Vec3> out;
  auto rock = [&](const Vec3& p) { return !f.isFree(p); };
  for (double z = std::floor((c.z() - radius) / res); z <= std::floor((c.z() + radius) / res); ++z)
    for (double y = std::floor((c.y() - radius) / res); y <= std::floor((c.y() + radius) / res); ++y)
      for (double x = std::floor((c.x() - radius) / res); x <= std::floor((c.x() + radius) / res); ++x) {
        const Vec3 v((x + 0.5) * res, (y + 0.5) * res, (z + 0.5) * res);
        const Vec3 n = c.cwiseMax(v - Vec3::Constant(half)).cwiseMin(v + Vec3::Constant(half));
        if ((n - c).norm() > radius || !rock(v)) continue;
        bool surface = false;
        for (int a = 0; a < 3; ++a)
          for (double s : {-res, res}) {
            Vec3 w = v;
            w[a] += s;
            surface = surface || !rock(w);
          }
        if (surface) out.push_back(n);
      }
  return out;
}

TEST(RockPoints, MatchesBruteForceAndRespectsTheBuffer) {
  const OccupancyMap map = test::voxelizeOrFail(test::straightRoadway(CrossSection::rectangle(4.0, 3.0), 10.0));
  StatusOr<DistanceField> f = DistanceField::build(map);
  ASSERT_TRUE(f.ok());
  std::mt19937_64 rng(5);
  std::vector<Vec3> buf(20000);
  int checked = 0;
  for (int i = 0; i < 30; ++i) {
    const Vec3 c = test::randomPoint(rng, Aabb(Vec3(1, -1.8, 0.2), Vec3(9, 1.8, 2.8)));
    if (!f->isFree(c)) continue;
    const double radius = 1.0 + 0.05 * i;
    const RockPointsResult r = rockSurfacePoints(*f, c, radius, buf.data(), buf.size());
    std::vector<Vec3> got(buf.begin(), buf.begin() + std::ptrdiff_t(r.written));
    std::vector<Vec3> want = bruteForce(*f, c, radius);
    auto less = [](const Vec3& a, const Vec3& b) { return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3); };
    std::sort(got.begin(), got.end(), less);
    std::sort(want.begin(), want.end(), less);
    EXPECT_FALSE(r.truncated);
    ASSERT_EQ(got.size(), want.size()) << "centre " << c.transpose() << " radius " << radius;
    for (std::size_t k = 0; k < got.size(); ++k) EXPECT_LT((got[k] - want[k]).norm(), 1e-9);
    ++checked;
  }
  EXPECT_GT(checked, 10);
  // The cone variant: exactly the full result's points inside the cone.
  for (const Vec3& axis : {Vec3(1, 0, 0), Vec3(0, 1, 0.3), Vec3(-1, -1, -1)}) {
    const Vec3 c(5, 0.5, 1.2);
    const double half = 1.0;  // rad
    const RockPointsResult full = rockSurfacePoints(*f, c, 1.8, buf.data(), buf.size());
    std::vector<Vec3> want;
    for (std::size_t k = 0; k < full.written; ++k) {
      const Vec3 d = buf[k] - c;
      if (d.dot(axis.normalized()) >= std::cos(half) * d.norm()) want.push_back(buf[k]);
    }
    std::vector<Vec3> got(buf.size());
    const RockPointsResult part = rockSurfacePoints(*f, c, 1.8, ViewCone{axis, half}, got.data(), got.size());
    got.resize(part.written);
    EXPECT_GT(want.size(), 0u);
    ASSERT_EQ(got.size(), want.size()) << axis.transpose();
    for (std::size_t k = 0; k < got.size(); ++k) EXPECT_LT((got[k] - want[k]).norm(), 1e-12);  // same scan order
  }
  // A small buffer: the count is still right, and truncated says so.
  const Vec3 c(5, 1.5, 1.5);
  Vec3 small[4];
  const RockPointsResult r = rockSurfacePoints(*f, c, 1.0, small, 4);
  EXPECT_EQ(r.written, 4u);
  EXPECT_GT(r.found, 4u);
  EXPECT_TRUE(r.truncated);
  EXPECT_TRUE(rockSurfacePoints(*f, Vec3(std::nan(""), 0, 0), 1.0, small, 4).truncated);
}

}  // namespace
}  // namespace adit::map
