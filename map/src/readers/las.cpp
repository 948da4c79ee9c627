// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/readers/las.hpp"

#include <cmath>

#include "adit/map/map_io.hpp"
#include "common.hpp"

namespace adit::map {

using namespace readers_internal;

StatusOr<Geometry> parseLas(const std::string& b, const std::string& name, const ReadLimits& limits) {
  if (b.size() < 4 || b.compare(0, 4, "LASF") != 0) return invalidArgument(at(name, 0) + ": not a LAS file (no LASF magic)");
  if (b.size() < 227) return dataLoss(name + ": truncated LAS header (" + std::to_string(b.size()) + " bytes, need 227)");
  const int major = static_cast<unsigned char>(b[24]), minor = static_cast<unsigned char>(b[25]);
  if (major != 1 || minor > 4)
    return invalidArgument(at(name, 24) + ": LAS version " + std::to_string(major) + "." + std::to_string(minor) +
                           " is not supported (1.0-1.4)");
  const std::uint16_t header_size = loadLE<std::uint16_t>(b, 94);
  const std::uint32_t data_offset = loadLE<std::uint32_t>(b, 96);
  const std::uint8_t raw_format = static_cast<std::uint8_t>(b[104]);
  const std::uint16_t record_len = loadLE<std::uint16_t>(b, 105);
  // LAZ marks compression in the top bits of the point format (laszip's convention).
  if (raw_format & 0xC0) return invalidArgument(name + ": " + kLazNotSupported);
  const int format = raw_format;
  static const int kMinRecord[11] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  if (format > 10) return invalidArgument(at(name, 104) + ": unknown point data format " + std::to_string(format));
  if (record_len < kMinRecord[format])
    return invalidArgument(at(name, 105) + ": point record length " + std::to_string(record_len) + " is below " +
                           std::to_string(kMinRecord[format]) + " bytes for point format " + std::to_string(format));
  if (header_size < 227 || header_size > b.size())
    return invalidArgument(at(name, 94) + ": header size " + std::to_string(header_size) + " is impossible");
  if (data_offset < header_size || data_offset > b.size())
    return dataLoss(at(name, 96) + ": offset to point data " + std::to_string(data_offset) + " lies outside the file (" +
                    std::to_string(b.size()) + " bytes)");
  std::uint64_t count = loadLE<std::uint32_t>(b, 107);
  if (minor >= 4 && header_size >= 255) {
    const std::uint64_t extended = loadLE<std::uint64_t>(b, 247);
    if (extended != 0) count = extended;
  }
  if (count == 0) return invalidArgument(at(name, 107) + ": the LAS file has no points");
  if (count > limits.max_points)
    return outOfRange(at(name, 107) + ": header announces " + std::to_string(count) + " points, more than the limit of " +
                      std::to_string(limits.max_points));
  const std::uint64_t avail = b.size() - data_offset;
  if (count * record_len > avail)
    return dataLoss(at(name, data_offset) + ": truncated: header says " + std::to_string(count) + " points x " +
                    std::to_string(record_len) + " bytes, only " + std::to_string(avail) + " bytes follow");
  double scale[3], offset[3];
  for (int i = 0; i < 3; ++i) {
    scale[i] = loadLE<double>(b, 131 + 8 * std::size_t(i));
    offset[i] = loadLE<double>(b, 155 + 8 * std::size_t(i));
    if (!std::isfinite(scale[i]) || scale[i] == 0 || !std::isfinite(offset[i]))
      return invalidArgument(at(name, 131 + 8 * std::size_t(i)) + ": scale/offset of axis " + "xyz"[i] +
                             " is zero or not finite");
  }
  Geometry g;
  g.points.resize(count);
  for (std::uint64_t k = 0; k < count; ++k) {
    const std::size_t o = data_offset + k * record_len;
    g.points[k] = Vec3(double(loadLE<std::int32_t>(b, o)) * scale[0] + offset[0],
                       double(loadLE<std::int32_t>(b, o + 4)) * scale[1] + offset[1],
                       double(loadLE<std::int32_t>(b, o + 8)) * scale[2] + offset[2]);
    // Finite scale and offset can still overflow (1e300 x 2^31): the point is not a coordinate.
    if (!g.points[k].allFinite())
      return invalidArgument(at(name, o) + ": point " + std::to_string(k + 1) +
                             " scales to a non-finite coordinate (header scale/offset too large)");
  }
  return g;
}

StatusOr<Geometry> readLas(const std::string& path, const ReadLimits& limits) {
  if (extensionOf(path) == ".laz") return invalidArgument(path + ": " + kLazNotSupported);
  ADIT_ASSIGN_OR_RETURN(std::string bytes, readFile(path));
  return parseLas(bytes, path, limits);
}

}  // namespace adit::map
