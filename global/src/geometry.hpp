// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Small geometric helpers shared by the global layer's sources.
#include <algorithm>
#include <cmath>
#include <utility>

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

/// Parameters (t, u) in [0, 1]^2 of the closest points of segments a0-a1 and b0-b1 (for
/// parallel segments, one such pair).
inline std::pair<double, double> closestSegmentParameters(const map::Vec3& a0, const map::Vec3& a1,
                                                          const map::Vec3& b0, const map::Vec3& b1) {
  const map::Vec3 d1 = a1 - a0, d2 = b1 - b0, r = a0 - b0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  if (a <= 1e-18 && e <= 1e-18) return {0.0, 0.0};
  if (a <= 1e-18) return {0.0, std::clamp(f / e, 0.0, 1.0)};
  const double c = d1.dot(r);
  if (e <= 1e-18) return {std::clamp(-c / a, 0.0, 1.0), 0.0};
  const double b = d1.dot(d2), denom = a * e - b * b;
  double t = denom > 1e-12 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double u = (b * t + f) / e;
  if (u < 0) u = 0, t = std::clamp(-c / a, 0.0, 1.0);
  else if (u > 1) u = 1, t = std::clamp((b - c) / a, 0.0, 1.0);
  return {t, u};
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
