// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Top-view pictures of a map (Cairo): free space seen from above, coloured by floor elevation,
/// or a horizontal slice at one height; with a scale bar, a north arrow, a legend and a title.
/// PNG or SVG by the output extension; written atomically.
///
///   TopViewOptions o;
///   o.title = "district";
///   Status s = renderTopView(map, o, "top.png");
///
/// Picture: north (+y) up, east (+x) right. The octree is read once (pruned leaves are filled as
/// whole squares) into a raster over the map's x-y bounds; a pixel is drawn as free when any free
/// voxel column overlaps it, so a roadway never disappears however small the scale (it is at
/// least one pixel wide). Projection mode colours a free pixel by the lowest floor (bottom of the
/// lowest free voxel) of the columns it covers, with a viridis-like ramp; everything else is the
/// dark background. The automatic scale makes the longer side about max_pixels, but never so
/// small that a roadway of min_roadway_width_m is under 3 pixels (then the picture grows, up to
/// max_megapixels, and an error says so if even that is not enough). Raw voxel states are drawn:
/// the map's unknown-space policy does not turn unknown into free here.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "adit/map/occupancy_map.hpp"

namespace adit::tools {

struct TopViewOptions {
  /// Slice height [m]. Unset: a projection of the whole height (free if any voxel of the
  /// column is free), coloured by the floor elevation of the column.
  std::optional<double> slice_z_m;
  double slice_band_m = 0.0;      ///< with slice_z_m: free if any voxel within +-band/2 is free
  double pixels_per_m = 0.0;      ///< 0 = chosen so that the longer side is about max_pixels
  int max_pixels = 2000;          ///< cap on the longer side of the map area
  std::string title;              ///< drawn at the top; empty = none
  /// Automatic scale only: never draw a roadway this wide [m] under 3 pixels.
  double min_roadway_width_m = 4.0;
  /// Hard cap on the whole picture (map area and annotations) [millions of pixels].
  double max_megapixels = 40.0;
  /// With a map: draw only this x-y window of it (z ignored), e.g. the part of a district a run
  /// crossed. Unset: the whole map.
  std::optional<adit::map::Aabb> view_box_m;
};

/// Colours of the raster (0xRRGGBB), so that callers and tests can recognise them.
inline constexpr std::uint32_t kTopViewBackground = 0x202226;   ///< rock/unknown; slice: unknown
inline constexpr std::uint32_t kTopViewSliceFree = 0xEDE6D3;    ///< slice: free
inline constexpr std::uint32_t kTopViewSliceOccupied = 0x8E735C;  ///< slice: occupied (rock)

/// What renderTopView drew, for callers that report it or look up pixels.
struct TopViewInfo {
  int width_px = 0, height_px = 0;  ///< whole picture (SVG: in user units = pixels)
  double pixels_per_m = 0.0;        ///< scale of the map area
  bool scale_raised = false;        ///< automatic scale raised to keep thin roadways visible
  int map_left_px = 0, map_top_px = 0, map_width_px = 0, map_height_px = 0;  ///< map area
  double x_min_m = 0.0, y_max_m = 0.0;  ///< world x of the map area's left, y of its top edge
  std::optional<double> floor_min_m, floor_max_m;  ///< projection: ends of the colour ramp
  double scale_bar_m = 0.0;         ///< length of the scale bar
  std::uint64_t free_pixels = 0;    ///< map-area pixels drawn as free
  /// Marker and profile labels (see label_layout.hpp): drawn, markers named by a merged label,
  /// displaced with a leader line, and left overlapping something for want of room (0 expected).
  std::size_t labels = 0, labels_merged = 0, label_leaders = 0, label_overlaps = 0;

  /// Picture coordinates (column, row; pixel i spans [i, i+1)) of a world point.
  double columnOf(double x_m) const { return map_left_px + (x_m - x_min_m) * pixels_per_m; }
  double rowOf(double y_m) const { return map_top_px + (y_max_m - y_m) * pixels_per_m; }
};

/// Writes `path` (.png or .svg, case-insensitive). Errors: invalid options, unknown extension,
/// missing or unwritable directory, picture too large; a failed call leaves no file behind.
/// `info`, when given, is filled on success.
adit::Status renderTopView(const adit::map::OccupancyMap& map, const TopViewOptions& options,
                                const std::string& path, TopViewInfo* info = nullptr);

}  // namespace adit::tools
