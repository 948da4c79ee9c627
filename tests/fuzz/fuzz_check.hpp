// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// What every reader promises about a result it returns ok: the fuzzers abort when a promise is
// broken, so a reader that "succeeds" with garbage is a finding like a crash.
#include <cstdio>
#include <cstdlib>

#include "adit/map/readers/geometry.hpp"

namespace adit::fuzz {

[[noreturn]] inline void broken(const char* what) {
  std::fprintf(stderr, "reader invariant broken: %s\n", what);
  std::abort();
}

/// Points exist and are finite; every triangle indexes an existing point.
inline void checkGeometry(const map::Geometry& g) {
  if (g.points.empty()) broken("ok result without points");
  if (map::readers_internal::firstNonFinite(g.points) >= 0) broken("non-finite point in an ok result");
  for (const auto& t : g.triangles)
    for (std::uint32_t i : t)
      if (i >= g.points.size()) broken("triangle index past the vertices");
  if (g.viewpoint && !g.viewpoint->allFinite()) broken("non-finite viewpoint");
}

/// The input split as [selector byte][rest]; empty input gives selector 0 and no bytes.
struct Selected {
  unsigned selector;
  std::string bytes;
};
inline Selected select(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return {0, {}};
  return {data[0], std::string(reinterpret_cast<const char*>(data) + 1, size - 1)};
}

}  // namespace adit::fuzz
