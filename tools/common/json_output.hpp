// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// What every JSON document and CSV table the `adit` verbs write shares, so that scripts can rely
/// on it: the document's kind and version as its first two keys (`schema`, `schema_version`; the
/// JSON Schemas under docs/schemas/ are named after `schema`), and numbers written at the
/// precision of their quantity (docs/formats.md, "Numbers"): positions, lengths and clearances to
/// the millimetre, times to the microsecond. Simulated times are step x dt, which in binary
/// floating point is 52.900000000000006 for step 529 at dt 0.1; rounded to the microsecond they
/// print as the step times they are (52.9).

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>

#include "adit/map/types.hpp"

namespace adit::tools {

/// Bumped when a field is renamed, removed or changes meaning; new fields do not bump it.
inline constexpr int kSchemaVersion = 1;

/// `j` with "schema": `schema` and "schema_version" as its first keys, its own keys after them in
/// their order (any "schema" or "schema_version" of its own is replaced). Taken by value and its
/// members moved: a simulation's trajectory is not copied.
inline nlohmann::ordered_json stamped(const std::string& schema, nlohmann::ordered_json j) {
  nlohmann::ordered_json out;
  out["schema"] = schema;
  out["schema_version"] = kSchemaVersion;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "schema" && it.key() != "schema_version") out[it.key()] = std::move(it.value());
  return out;
}

/// Rounded to `decimals` places, non-finite values kept (callers map them to null themselves).
inline double roundTo(double v, int decimals) {
  if (!std::isfinite(v)) return v;
  const double scale = std::pow(10.0, decimals);
  const double r = std::round(v * scale) / scale;
  return r == 0.0 ? 0.0 : r;  // no "-0.0"
}

/// Positions, lengths, clearances, radii: millimetres (3 decimals of a metre); a survey holds no
/// more and a voxel is 50-200 mm.
inline double mm(double metres) { return roundTo(metres, 3); }
/// Times in seconds, simulated or measured: microseconds (6 decimals).
inline double us(double seconds) { return roundTo(seconds, 6); }
/// Speeds (m/s): a millimetre per second.
inline double mmPerS(double v) { return roundTo(v, 3); }
/// Microsecond counts (step times already in us): a tenth of a microsecond.
inline double tenthUs(double micros) { return roundTo(micros, 1); }
/// Ratios and fractions: 6 decimals.
inline double ratio(double v) { return roundTo(v, 6); }

/// A point as [x, y, z] in millimetres.
inline nlohmann::ordered_json mmPoint(const map::Vec3& p) { return {mm(p.x()), mm(p.y()), mm(p.z())}; }
/// mm(v), or null when v is not finite (a clearance with nothing in range).
inline nlohmann::ordered_json mmOrNull(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(mm(v)) : nlohmann::ordered_json(nullptr);
}

/// A CSV field with `decimals` places, the trailing zeros dropped ("52.9", "3", "-0.125").
inline std::string csvNumber(double v, int decimals) {
  if (!std::isfinite(v)) return "";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, roundTo(v, decimals));
  std::string s = b;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  return s == "-0" ? "0" : s;
}

}  // namespace adit::tools
