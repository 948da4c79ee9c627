// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Roadways generated in code for tests: small survey networks with known geometry.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/map/survey_network.hpp"

namespace adit::test {

/// One straight roadway from (0,0,0) to (length, 0, rise).
map::SurveyNetwork straightRoadway(const map::CrossSection& section, double length_m = 12.0,
                                   double resolution_m = 0.2, double rise_m = 0.0);
/// Two roadways meeting at a right angle (an L), plus a cross-cut making a T.
map::SurveyNetwork junctionNetwork(double resolution_m = 0.2);
/// Two parallel 30 m roadways 16 m apart joined by a cross-cut at each end: a loop, so that one
/// branch can be blocked and the route go round by the other.
map::SurveyNetwork ladderNetwork(double resolution_m = 0.2);
/// A roadway with several bends and a gradient, stations given in the schema order.
map::SurveyNetwork bentRoadway(const map::CrossSection& section, double resolution_m = 0.2);

/// A coal district `width_m` east by `depth_m` north: two parallel mains along the south edge,
/// cross-cuts every 100 m, and longwall panels whose gate roads (every `panel_m`) run north to
/// faces at the far edge. Mostly rock: the benchmark for memory-bounded distance fields.
map::SurveyNetwork syntheticDistrict(double width_m = 2000.0, double depth_m = 1000.0,
                                     double resolution_m = 0.2, double panel_m = 250.0);

/// A generated roadway with a name for parameterised tests.
struct NamedNetwork {
  const char* name;
  map::SurveyNetwork net;
};

/// The roadways every oracle test runs on: a straight rectangle, a sloped arch (both
/// `straight_length_m` long), a bent trapezoid and a network of junctions.
std::vector<NamedNetwork> oracleRoadways(double straight_length_m = 10.0);

/// Points a voxel apart filling `box` (e.g. the voxels of a roof fall, for setVoxels).
std::vector<map::Vec3> pointsInBox(const map::Aabb& box, double resolution_m);

/// voxelize() that fails the current test on error.
map::OccupancyMap voxelizeOrFail(const map::SurveyNetwork& net);

/// Uniform random point inside a box, from a seeded engine (tests are deterministic).
map::Vec3 randomPoint(std::mt19937_64& rng, const map::Aabb& box);

}  // namespace adit::test
