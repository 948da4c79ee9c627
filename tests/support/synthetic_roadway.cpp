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

SurveyNetwork ladderNetwork(double resolution_m) {
  SurveyNetwork net;
  net.name = "ladder";
  net.resolution_m = resolution_m;
  net.stations = {{"A", Vec3(0, 0, 0)}, {"B", Vec3(30, 0, 0)}, {"C", Vec3(0, 16, 0)}, {"D", Vec3(30, 16, 0)}};
  net.sections = {{"s", CrossSection::rectangle(4.0, 3.0)}};
  net.roadways = {{"south", {"A", "B"}, "s"}, {"north", {"C", "D"}, "s"}, {"west", {"A", "C"}, "s"},
                  {"east", {"B", "D"}, "s"}};
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

SurveyNetwork syntheticDistrict(double width_m, double depth_m, double resolution_m, double panel_m) {
  SurveyNetwork net;
  net.name = "synthetic-district";
  net.resolution_m = resolution_m;
  net.sections = {{"main", CrossSection::arch(4.8, 1.5)},
                  {"gate", CrossSection::rectangle(4.5, 3.5)},
                  {"face", CrossSection::rectangle(4.2, 3.0)}};
  auto z = [](double x, double y) { return -0.03 * x + 0.04 * y; };  // a few degrees of dip
  std::vector<std::string> main_s, return_s;
  for (double x = 0; x <= width_m + 1e-9; x += 100.0) {
    const std::string m = "M" + std::to_string(int(x)), r = "R" + std::to_string(int(x));
    net.stations[m] = Vec3(x, 0, z(x, 0));
    net.stations[r] = Vec3(x, 40, z(x, 40));
    main_s.push_back(m);
    return_s.push_back(r);
    net.roadways.push_back({"crosscut-" + std::to_string(int(x)), {m, r}, "gate"});
  }
  net.roadways.push_back({"main", main_s, "main"});
  net.roadways.push_back({"return", return_s, "main"});
  int gate = 0;
  std::string previous_top;
  for (double x = 50.0; x < width_m; x += panel_m, ++gate) {
    const std::string g = "G" + std::to_string(gate);
    net.stations[g + "a"] = Vec3(x, 40, z(x, 40));
    net.stations[g + "b"] = Vec3(x, depth_m, z(x, depth_m));
    // The gate road leaves the return airway at a station of its own on the return's line.
    net.roadways.push_back({"gate-" + std::to_string(gate), {g + "a", g + "b"}, "gate"});
    if (gate % 2 == 1) net.roadways.push_back({"face-" + std::to_string(gate / 2), {previous_top, g + "b"}, "face"});
    previous_top = g + "b";
  }
  return net;
}

std::vector<NamedNetwork> oracleRoadways(double straight_length_m) {
  return {
      {"straight_rectangle", straightRoadway(CrossSection::rectangle(4.0, 3.0), straight_length_m, 0.2)},
      {"straight_arch_sloped", straightRoadway(CrossSection::arch(4.0, 2.0), straight_length_m, 0.25, 0.6)},
      {"bent_trapezoid", bentRoadway(CrossSection::trapezoid(4.0, 3.0, 3.0), 0.25)},
      {"junctions", junctionNetwork(0.25)},
  };
}

std::vector<map::Vec3> pointsInBox(const map::Aabb& box, double r) {
  std::vector<map::Vec3> pts;
  for (double x = box.min.x(); x <= box.max.x(); x += r)
    for (double y = box.min.y(); y <= box.max.y(); y += r)
      for (double z = box.min.z(); z <= box.max.z(); z += r) pts.emplace_back(x, y, z);
  return pts;
}

map::OccupancyMap voxelizeOrFail(const SurveyNetwork& net) {
  adit::StatusOr<map::OccupancyMap> m = map::voxelize(net);
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
