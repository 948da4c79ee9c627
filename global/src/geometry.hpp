// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Small geometric helpers shared by the global layer's sources.
#include <algorithm>
#include <cmath>

#include "adit/map/distance_field.hpp"

namespace adit::global {

/// Parameter in [0, 1] of the point of segment a-b nearest to p.
inline double segmentParameter(const map::Vec3& p, const map::Vec3& a, const map::Vec3& b) {
  const map::Vec3 d = b - a;
  const double len2 = d.squaredNorm();
  if (len2 <= 0) return 0.0;
  return std::clamp((p - a).dot(d) / len2, 0.0, 1.0);
}

inline double segmentDistance(const map::Vec3& p, const map::Vec3& a, const map::Vec3& b) {
  return (p - (a + segmentParameter(p, a, b) * (b - a))).norm();
}

/// Every point of a-b sampled at most `step` apart (ends included) has field clearance >= need.
inline bool segmentClear(const map::DistanceField& field, const map::Vec3& a, const map::Vec3& b, double need,
                         double step) {
  const double len = (b - a).norm();
  const int n = std::max(1, int(std::ceil(len / step)));
  for (int k = 0; k <= n; ++k)
    if (field.distance(a + (b - a) * (double(k) / n)) < need) return false;
  return true;
}

}  // namespace adit::global
