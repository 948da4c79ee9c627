// SPDX-License-Identifier: BSD-3-Clause
// ASPRS LAS 1.0-1.4 bytes -> parseLas, adit's own header and record decoder.
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/las.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<adit::map::Geometry> g = adit::map::parseLas(bytes, "fuzz.las");
  if (g.ok()) adit::fuzz::checkGeometry(*g);
  return 0;
}
