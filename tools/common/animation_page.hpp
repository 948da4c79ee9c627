// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// The animated page of a run (`adit simulate --html`, and later the fusion runs): one
/// self-contained HTML file that works offline (no network, no external asset), showing the
/// figure's static picture (map top view, expected path, static obstacles: whatever the caller put
/// in the Figure) with the robot and the moving obstacles animated over it, a time slider,
/// play/pause, speed, and the robot's status per frame (following, yielding, detouring, stuck,
/// arrived, ...). The picture is embedded as a PNG (base64); world coordinates are mapped to it
/// with the TopViewInfo the renderer returns, so the animation lines up with the picture exactly.
///
///   Figure fig(options);  fig.setMap(&map);  fig.addLine(expected_path);  ...
///   AnimationPageInput in;
///   in.title = "tian2016 straight";  in.robot_radius_m = 0.3;
///   in.movers = {{"obstacle 1", 0.3, kFigureMoving}};
///   in.frames.push_back({0.0, start, "following", {mover_at_0}});
///   Status s = writeAnimationPage(fig, in, "run.html");   // atomic
///
/// The page: the picture with the moving obstacles (discs of their world radii, numbered, their
/// whole tracks dashed and the part driven so far solid) and the robot (a disc of its radius
/// coloured by its status, a heading tick, the driven path and a trail of the last 8 s fading
/// out); beside it a clock, the status, the robot's x/y/z and speed, a legend and the summary.
/// It plays on opening at a speed that shows the run in about half a minute; `run.html#t=42.5`
/// opens it paused at 42.5 s (for stills). Keys: space, arrows, Home/End.
/// What a test can read in the DOM (attributes of <html>): data-ready="1" once started,
/// data-frame / data-time / data-status of the frame shown, data-playing, and data-errors, the
/// number of script errors and blocked fetches (their text is in #errors). A
/// Content-Security-Policy forbids every network fetch. Size: about 3.6 bytes per stored number,
/// e.g. 218 kB of frame data for 3000 frames with 10 moving obstacles.
/// Screenshot (README): `cmake -DPAGE=run.html -DSCREENSHOT=shot.png [-DAT=seconds]
/// -P tests/tools/browser_page.cmake` (Debian's chromium).

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "adit/map/types.hpp"
#include "adit/status.hpp"
#include "common/figure.hpp"

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
};

struct AnimationPageInput {
  std::string title;
  double robot_radius_m = 0.3;
  std::vector<PageMover> movers;
  std::vector<PageFrame> frames;  ///< time-ordered, at least one
  /// Lines shown in the page's summary panel, e.g. {"outcome", "arrived"}, {"arrival time", "97.3 s"}.
  std::vector<std::pair<std::string, std::string>> summary;
};

/// What was written, for callers that report it (a long run's page should stay small).
struct AnimationPageInfo {
  std::size_t page_bytes = 0;        ///< the whole HTML file
  std::size_t background_bytes = 0;  ///< the embedded PNG (before base64)
  std::size_t frame_data_bytes = 0;  ///< the encoded frames (JSON text)
  std::size_t frames = 0;
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

/// `s` with & < > " ' as HTML entities (for text and attribute values of generated pages).
std::string htmlEscape(const std::string& s);

}  // namespace adit::tools
