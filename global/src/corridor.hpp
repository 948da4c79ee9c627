// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Corridor: the union of capsules (axis segment + radius) around a route. OMPL's states must lie
// in it and its sampler draws only from it, never from the mine's bounding box.
#include <random>
#include <vector>

#include "adit/global/roadway_graph.hpp"

namespace adit::global {

class Corridor {
 public:
  /// From a route's axis; the axis is first simplified (points within `tolerance_m` of a straight
  /// run are dropped, keeping the largest radius) so that membership tests stay cheap.
  Corridor(const Route& route, double tolerance_m);
  /// The whole box (the plain-OMPL baseline): every point of it is "in the corridor".
  explicit Corridor(const map::Aabb& box);

  bool contains(const map::Vec3& p) const;
  /// Uniform-ish point of the corridor: a segment by length, a point on it, a point in the ball.
  /// `axis_point` (optional) receives the axis point the sample was drawn around.
  map::Vec3 sample(std::mt19937_64& rng, map::Vec3* axis_point = nullptr) const;
  /// The corridor axis point nearest to p (ground mode reads the floor under it).
  map::Vec3 nearestAxisPoint(const map::Vec3& p) const;
  const map::Aabb& bounds() const { return bounds_; }
  bool isBox() const { return box_; }

 private:
  struct Segment {
    map::Vec3 a, b;
    double radius;
    map::Aabb box;
  };
  std::vector<Segment> segments_;
  std::vector<double> cumulative_;  // sampling weights
  map::Aabb bounds_;
  bool box_ = false;
};

}  // namespace adit::global
