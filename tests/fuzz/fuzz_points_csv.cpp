// SPDX-License-Identifier: BSD-3-Clause
// Points CSV text (`adit map query --points`) -> parsePointsCsv; every point that parses must
// print round-trip exact (the query output is joined back to its input).
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/points_csv.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<std::vector<adit::map::Vec3>> pts = adit::tools::parsePointsCsv(text, "fuzz.csv");
  if (!pts.ok()) return 0;
  for (const adit::map::Vec3& p : *pts)
    for (int i = 0; i < 3; ++i) {
      const std::string s = adit::tools::roundTripNumber(p[i]);
      if (std::strtod(s.c_str(), nullptr) != p[i]) std::abort();
    }
  return 0;
}
