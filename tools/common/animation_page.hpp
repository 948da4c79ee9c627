// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The animated page of a run (`adit simulate --html`, and the campaign's replay commands): one
/// self-contained HTML file that works offline (no network, no external asset) and replays the
/// run. The picture under it is the figure's (map top view, static obstacles, start, goal:
/// whatever stands the whole run, and whatever else the caller put in the Figure), embedded as a
/// PNG (base64); world coordinates are mapped to it with the TopViewInfo the renderer returns, so
/// the drawing lines up with the picture exactly. Everything that happens during the run is drawn
/// by the page's script at its time, so that at t the page shows only what had happened by t.
///
///   Figure fig(options);  fig.setMap(&map);  fig.addMarker(start);  ...   // the standing part
///   AnimationPageInput in;
///   in.title = "tian2016 straight";  in.robot_radius_m = 0.3;
///   in.movers = {{"obstacle 1", 0.3, kFigureMoving}};
///   in.frames.push_back({0.0, start, "following", {mover_at_0}});
///   in.initial_path = expected_path;
///   in.events.push_back({53.0, "replan", "expected path blocked", "replanning", {}, 0.0, new_path});
///   Status s = writeAnimationPage(fig, in, "run.html");   // atomic
///
/// The page at time t: the robot (a disc of its radius coloured by its status, a heading tick,
/// the path driven so far and a trail of the last 8 s fading out); the moving obstacles (discs of
/// their world radii at their positions, tagged as in the legend by the number their name ends in
/// or a short name, their whole tracks dashed and the part driven so far solid); the expected path
/// in force (the initial one, then each replan's from its time, the superseded ones faded); each
/// roof fall's ball from its time; the rock the sensor saw from when it saw it; the sub-goals
/// chosen so far (the one in force larger). Beside it a clock, the status (on an event's frame the
/// event's, e.g. "replanning"), the robot's x/y/z and speed, a legend, the events and the summary.
/// Under the slider a strip of the status over the run and one mark per event (replan, roof fall,
/// escape, stuck, collision, arrival or end, ...) at its time: clicking a mark, or the event in the list,
/// pauses on the event's frame. It plays on opening at a speed that shows the run in about half a
/// minute; `run.html#t=42.5` opens it paused at 42.5 s (for stills). Keys: space, arrows, Home/End.
/// What a test can read in the DOM (attributes of <html>): data-ready="1" once started,
/// data-frame / data-time / data-status of the frame shown, data-playing, data-errors (the number
/// of script errors and blocked fetches; their text is in #errors), data-events (the number of
/// events), and for the frame shown data-event (the kinds of its events, space-separated),
/// data-events-past, data-paths (replanned paths so far), data-falls, data-sensed and
/// data-subgoals (how many of each are drawn). The marks are `#marks .mark` buttons, the list's
/// entries `#event-list .ev`, both with data-event (index), data-kind and data-frame; the marks
/// also data-t. A Content-Security-Policy forbids every network fetch. Size: about 3.6 bytes per
/// stored number, e.g. 218 kB of frame data for 3000 frames with 10 moving obstacles.
/// Screenshot (README): `cmake -DPAGE=run.html -DSCREENSHOT=shot.png [-DAT=seconds]
/// -P tests/tools/browser_page.cmake` (Debian's chromium).

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "adit/map/types.hpp"
#include "adit/status.hpp"
#include "common/figure.hpp"
#include "common/markup.hpp"  // htmlEscape, for the page's callers too

namespace adit::tools {

/// A moving obstacle shown on the page (its positions are per frame).
struct PageMover {
  std::string name;
  double radius_m = 0.3;
  std::uint32_t colour = kFigureMoving;
};

struct PageFrame {
  double t_s = 0.0;
  adit::map::Vec3 robot = adit::map::Vec3::Zero();
  std::string status;                  ///< e.g. "following"; shown beside the clock
  std::vector<adit::map::Vec3> movers;  ///< one per AnimationPageInput::movers, same order
  /// The robot's heading [rad] (a ground robot's body), drawn when the input gives a box
  /// footprint; NaN: not known (the page turns the box along the motion).
  double yaw = std::numeric_limits<double>::quiet_NaN();
};

/// Something that happened during the run: one mark on the page's timeline (clicking it shows
/// that moment), and what the picture gains from its time on.
struct PageEvent {
  double t_s = 0.0;
  std::string kind;    ///< short, e.g. "replan", "roof_fall", "stuck", "arrived" (the mark's class)
  std::string label;   ///< one line: the mark's tooltip and the event list, e.g. the replan's reason
  /// Shown as the robot's status on the frame of the event (the first at or after t_s), e.g.
  /// "replanning"; empty: that frame's own status.
  std::string status;
  /// A disc drawn from t_s on (a roof fall's ball): radius 0 is none.
  adit::map::Vec3 center = adit::map::Vec3::Zero();
  double radius_m = 0.0;
  /// The expected path from t_s on (a replan's): it replaces the one before, which is drawn faded.
  /// Empty: the event changes no path.
  std::vector<adit::map::Vec3> path;
};

/// A point that appears at a time and stays (sensed rock, a chosen sub-goal).
struct PagePoint {
  double t_s = 0.0;
  adit::map::Vec3 p = adit::map::Vec3::Zero();
};

struct AnimationPageInput {
  std::string title;
  double robot_radius_m = 0.3;
  /// A ground robot's box footprint (length along its heading, width across): drawn as that
  /// box, turned to each frame's yaw, instead of the disc of robot_radius_m. 0: a disc.
  double robot_length_m = 0.0, robot_width_m = 0.0;
  bool boxRobot() const { return robot_length_m > 0.0 && robot_width_m > 0.0; }
  std::vector<PageMover> movers;
  std::vector<PageFrame> frames;  ///< time-ordered, at least one
  /// The expected path at the first frame (drawn by the page, so that a replan can fade it); may
  /// be empty when the caller drew it into the picture instead.
  std::vector<adit::map::Vec3> initial_path;
  std::vector<PageEvent> events;       ///< time-ordered
  std::vector<PagePoint> sensed;       ///< rock the robot's sensor returned, when (time-ordered)
  std::vector<PagePoint> subgoals;     ///< each sub-goal from the time it was chosen (time-ordered)
  /// Lines shown in the page's summary panel, e.g. {"outcome", "arrived"}, {"arrival time", "97.3 s"}.
  std::vector<std::pair<std::string, std::string>> summary;
};

/// What was written, for callers that report it (a long run's page should stay small).
struct AnimationPageInfo {
  std::size_t page_bytes = 0;        ///< the whole HTML file
  std::size_t background_bytes = 0;  ///< the embedded PNG (before base64)
  std::size_t frame_data_bytes = 0;  ///< the encoded frames (JSON text)
  std::size_t frames = 0;
  std::size_t events = 0;            ///< marks on the timeline
};

/// Renders `background` to PNG in memory and writes the page to `path` atomically. Errors: an
/// empty or non-monotonic frame list, NaN coordinates, a frame whose mover count differs from
/// `movers`, whatever Figure::renderPng refuses, an unwritable path. Text is HTML-escaped.
/// `info`, when given, is filled on success.
adit::Status writeAnimationPage(const Figure& background, const AnimationPageInput& input,
                                const std::string& path, AnimationPageInfo* info = nullptr);

/// The checks writeAnimationPage makes on `input` (frames, times, coordinates, radii, counts).
adit::Status validateAnimationPageInput(const AnimationPageInput& input);

/// The page's text for an already rendered background: `png` is the picture and `view` maps world
/// x-y to its pixels (columnOf/rowOf). writeAnimationPage is renderPng followed by this; exposed
/// so that a caller holding a picture (and the tests) can build a page without a Figure.
/// Positions are stored rounded to 1 mm and times to 1 ms, as per-series differences.
adit::StatusOr<std::string> animationPageHtml(const std::vector<unsigned char>& png,
                                              const TopViewInfo& view,
                                              const AnimationPageInput& input,
                                              AnimationPageInfo* info = nullptr);

/// animationPageHtml written to `path` atomically.
adit::Status writeAnimationPageHtml(const std::vector<unsigned char>& png, const TopViewInfo& view,
                                    const AnimationPageInput& input, const std::string& path,
                                    AnimationPageInfo* info = nullptr);

}  // namespace adit::tools
