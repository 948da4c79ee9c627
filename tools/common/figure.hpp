// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Figure: the one renderer every `adit` picture is drawn with (`map slice`, `plan`, `simulate`,
/// and the animated page's background). A figure is the map's top view (see render_topview.hpp:
/// free space coloured by floor elevation, or a slice at one height) with axes, a legend, a scale
/// bar and a north arrow, plus overlays in world coordinates: polylines (optionally coloured by a
/// per-vertex value such as time), markers with labels (start, goal, break points A, B, ...;
/// placed clear of each other by label_layout.hpp, merged when their markers crowd),
/// discs of a world radius (obstacles), and an optional side-profile panel under the map (height
/// along a route, since roadways climb). Without a map the figure is open space: its extent comes
/// from explicit world bounds or else from the overlays.
///
///   Figure fig(options);
///   fig.setMap(&map);
///   fig.addLine({path.points, kFigurePath, 2.5, false, {}, "expected path"});
///   fig.addMarker({start, MarkerShape::kCircle, kFigureStart, 9, "start"});
///   fig.setProfile(profile);
///   Status s = fig.render("plan.png");      // .png or .svg, written atomically
///
/// Overlays are drawn in the order added, above the map and below the annotations. Only x and y
/// of overlay points are used on the map; the side profile takes its own (distance, height)
/// series. Colours are 0xRRGGBB.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "adit/map/occupancy_map.hpp"
#include "adit/status.hpp"
#include "common/render_topview.hpp"

namespace adit::tools {

/// A palette the verbs share, so that a path looks the same in every picture.
inline constexpr std::uint32_t kFigurePath = 0xE4572E;        ///< expected / planned path
inline constexpr std::uint32_t kFigureTrajectory = 0x2E86DE;  ///< driven trajectory (no values)
inline constexpr std::uint32_t kFigureStart = 0x2ECC71;
inline constexpr std::uint32_t kFigureGoal = 0xF1C40F;
inline constexpr std::uint32_t kFigureBreakPoint = 0xFFFFFF;
inline constexpr std::uint32_t kFigureObstacle = 0xC0392B;     ///< static obstacles
inline constexpr std::uint32_t kFigureMoving = 0x9B59B6;       ///< moving obstacles and tracks
inline constexpr std::uint32_t kFigureBlocked = 0xFF3B3B;      ///< blocked roadways, roof falls

struct FigureLine {
  std::vector<adit::map::Vec3> points;  ///< world coordinates; x-y drawn
  std::uint32_t colour = kFigurePath;
  double width_px = 2.0;
  bool dashed = false;
  /// Optional, one per point (e.g. time): the line is then drawn in segments coloured along a
  /// ramp from the smallest to the largest value, and a colour bar is added to the legend.
  std::vector<double> values;
  std::string legend;        ///< legend entry; empty = none
  std::string values_label;  ///< colour-bar caption for `values`, e.g. "time [s]"
};

enum class MarkerShape { kCircle, kSquare, kTriangle, kDiamond, kCross };

struct FigureMarker {
  adit::map::Vec3 position = adit::map::Vec3::Zero();
  MarkerShape shape = MarkerShape::kCircle;
  std::uint32_t colour = kFigureBreakPoint;
  double size_px = 8.0;   ///< diameter
  std::string label;      ///< drawn beside the marker (e.g. "A", "start"); empty = none
  std::string legend;     ///< legend entry; empty = none
  /// Labels are placed in increasing priority (start and goal at 0 keep the best places). Labelled
  /// markers of one shape, colour and priority that sit closer than a label share one label.
  int label_priority = 1;
};

/// A disc of a world radius (an obstacle seen from above), filled and outlined.
struct FigureDisc {
  adit::map::Vec3 center = adit::map::Vec3::Zero();
  double radius_m = 0.5;
  std::uint32_t fill = kFigureObstacle;
  double fill_alpha = 0.55;
  std::uint32_t stroke = kFigureObstacle;
  std::string label;
  std::string legend;
};

/// The side-profile panel: series of (distance along the route, height), e.g. the path's centre
/// height and the roadway floor and roof under it, with labelled stations (A, B, ...).
struct ProfileSeries {
  std::vector<double> s_m;  ///< distance along the route [m], non-decreasing
  std::vector<double> z_m;  ///< height [m], same length as s_m
  std::uint32_t colour = kFigurePath;
  double width_px = 2.0;
  bool dashed = false;
  std::string legend;
};
struct ProfileLabel {
  double s_m = 0.0;
  double z_m = 0.0;
  std::string text;
  /// As FigureMarker::label_priority; labels of priority 0 (start, goal) never merge.
  int priority = 1;
};
struct SideProfile {
  std::string title = "Side profile: height z [m] along the route [m]";
  std::vector<ProfileSeries> series;
  std::vector<ProfileLabel> labels;
  double height_px = 180.0;  ///< panel height; the width is the map area's
};

class Figure {
 public:
  explicit Figure(TopViewOptions options = {});

  /// The background map (not owned; must outlive render()). Unset: open space.
  void setMap(const adit::map::OccupancyMap* map);
  /// World x-y extent to draw when there is no map (z ignored). Unset: the overlays' extent.
  void setWorldBounds(const adit::map::Aabb& bounds);

  void addLine(FigureLine line);
  void addMarker(FigureMarker marker);
  void addDisc(FigureDisc disc);
  void setProfile(SideProfile profile);

  /// Writes `path` (.png or .svg, case-insensitive), atomically. An SVG is vector throughout: the
  /// map as rectangles, one path per colour (group `map`), the overlays and annotations (group
  /// `drawing`), and every label, tick and legend line as a <text> element (group `text`).
  /// Errors: invalid options or
  /// overlays (NaN coordinates, mismatched value counts), unknown extension, missing or
  /// unwritable directory, picture too large, nothing to draw (no map, no bounds, no overlays).
  adit::Status render(const std::string& path, TopViewInfo* info = nullptr) const;
  /// The same picture as PNG bytes in memory (for pages that embed it).
  adit::Status renderPng(std::vector<unsigned char>* png, TopViewInfo* info = nullptr) const;

 private:
  enum class Output { kPng, kSvg };
  adit::Status draw(Output kind, const std::string& path, std::vector<unsigned char>* png,
                    TopViewInfo* info) const;

  TopViewOptions options_;
  const adit::map::OccupancyMap* map_ = nullptr;
  std::optional<adit::map::Aabb> bounds_;
  std::vector<FigureLine> lines_;
  std::vector<FigureMarker> markers_;
  std::vector<FigureDisc> discs_;
  std::optional<SideProfile> profile_;
};

}  // namespace adit::tools
