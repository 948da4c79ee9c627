// SPDX-License-Identifier: BSD-3-Clause
#include "support/synthetic_roadway.hpp"

namespace adit::test {

using map::CrossSection;
using map::SurveyNetwork;
using map::Vec3;

SurveyNetwork straightRoadway(const CrossSection& section, double length_m, double resolution_m, double rise_m) {
  SurveyNetwork net;
  net.name = "straight";
  net.resolution_m = resolution_m;
  net.stations = {{"A", Vec3(0, 0, 0)}, {"B", Vec3(length_m, 0, rise_m)}};
  net.sections = {{"s", section}};
  net.roadways = {{"road", {"A", "B"}, "s"}};
  return net;
}

SurveyNetwork junctionNetwork(double resolution_m) {
  SurveyNetwork net;
  net.name = "junction";
  net.resolution_m = resolution_m;
  net.stations = {{"A", Vec3(0, 0, 0)}, {"B", Vec3(14, 0, 0.3)}, {"C", Vec3(14, 10, 0.5)},
                  {"D", Vec3(6, 0, 0.13)}, {"E", Vec3(6, -8, 0.0)}};
  net.sections = {{"main", CrossSection::arch(4.0, 2.5)}, {"gate", CrossSection::rectangle(3.0, 3.0)}};
  net.roadways = {{"main", {"A", "D", "B"}, "main"}, {"branch", {"B", "C"}, "gate"}, {"crosscut", {"D", "E"}, "gate"}};
  return net;
}

SurveyNetwork bentRoadway(const CrossSection& section, double resolution_m) {
  SurveyNetwork net;
  net.name = "bent";
  net.resolution_m = resolution_m;
  net.stations = {{"P1", Vec3(0, 0, 0)}, {"P2", Vec3(8, 3, 0.4)}, {"P3", Vec3(12, 10, 0.9)}, {"P4", Vec3(20, 11, 1.0)}};
  net.sections = {{"s", section}};
  net.roadways = {{"bent", {"P1", "P2", "P3", "P4"}, "s"}};
  return net;
}

map::OccupancyMap voxelizeOrFail(const SurveyNetwork& net) {
  map::StatusOr<map::OccupancyMap> m = map::voxelize(net);
  if (!m.ok()) {
    ADD_FAILURE() << m.status().toString();
    std::abort();
  }
  return std::move(m).value();
}

Vec3 randomPoint(std::mt19937_64& rng, const map::Aabb& box) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return box.min + (box.max - box.min).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
}

}  // namespace adit::test
