// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The survey schema example exactly as issue 3 writes it: every reader test starts from it.
#include <string>

namespace adit::test {

inline const std::string kIssueSurveyExample =
    R"(resolution: 0.2                 # voxel edge, metres; frame: x east, y north, z up
stations:                       # id: [x, y, z of the roadway floor]
  S1: [0, 0, 0]
  S2: [300, 0, 3]
  S3: [300, 80, 4]
sections:                       # named cross-sections
  main: {shape: arch, width: 5.0, wall_height: 3.0}        # semicircular arch, rise = width/2
  gate: {shape: rectangle, width: 4.5, height: 3.5}
  drift: {shape: trapezoid, bottom_width: 4.0, top_width: 3.2, height: 3.0}
  haul: {shape: three_centred_arch, width: 5.5, wall_height: 2.8, rise: 1.8}
roadways:                       # centerlines through stations, each with one section
  - {name: main, stations: [S1, S2], section: main}
  - {name: crosscut-1, stations: [S2, S3], section: gate}
)";

/// The same network shrunk tenfold (30 m and 8 m roadways), quick enough to voxelize in loops.
inline std::string shortIssueSurveyExample() {
  std::string s = kIssueSurveyExample;
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"S2: [300, 0, 3]", "S2: [30, 0, 3]"},
                                 {"S3: [300, 80, 4]", "S3: [30, 8, 4]"}})
    s.replace(s.find(from), from.size(), to);
  return s;
}

}  // namespace adit::test
