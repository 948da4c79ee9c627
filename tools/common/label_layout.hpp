// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Label layout: where the renderer writes the text of each labelled marker (start, goal, break
/// points A, B, ...) so that no label covers another label or any marker, and every label stays
/// inside its drawing area. It is pure geometry in picture pixels, with no Cairo, so that it is
/// tested on its own; the renderer measures the text and draws what this returns.
///
/// Markers of one kind (same group) whose centres are closer than a label's size get one merged
/// label: "H, I", or "H–K" for a run of three or more consecutive ones. Each label (alone or
/// merged) is then placed greedily, in priority order (lower first, e.g. start and goal before
/// break points), at the first free candidate among 8 positions around its marker(s), on rings of
/// increasing distance. A label placed beyond the first ring gets a leader line back to its
/// marker; no leader line crosses another label. A label with no free candidate anywhere is placed at its least-overlapping candidate
/// and counted in `overlaps`, so a caller (or a test) can see that the picture was too crowded.

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace adit::tools {

/// An axis-aligned box in picture pixels (y down).
struct LabelBox {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double width() const { return x1 - x0; }
  double height() const { return y1 - y0; }
  bool intersects(const LabelBox& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
  /// Whether the disc of centre (cx, cy) and radius r reaches inside the box.
  bool touchesDisc(double cx, double cy, double r) const;
  /// Whether the segment (ax, ay)-(bx, by) passes through the box's interior.
  bool crossesSegment(double ax, double ay, double bx, double by) const;
};

/// One marker. An empty `text` is a marker that has no label but that labels must not cover.
struct LabelAnchor {
  double x = 0, y = 0;   ///< marker centre [px]
  double radius = 0;     ///< marker radius [px]
  std::string text;      ///< label; empty = none
  int priority = 1;      ///< placed in increasing order; ties keep input order
  /// Anchors merge only within one group (e.g. all break points); -1 never merges.
  int group = -1;
  /// Order within the group (A = 0, B = 1, ...): consecutive ones merge into a run "A–C".
  int sequence = 0;
  /// Whether other labels must keep off this marker (an obstacle disc drawn translucent need not).
  bool obstacle = true;
};

struct LabelLayoutParams {
  LabelBox area;              ///< labels stay inside
  double gap_px = 3.0;        ///< between a marker's edge and its label on the first ring
  double padding_px = 1.5;    ///< kept clear around every label box
  int rings = 8;              ///< candidate rings; ring k is k label heights further out
  /// Anchors of one group closer than this factor times the larger label's size merge.
  double merge_factor = 1.0;
};

/// A placed label: the anchors it names, its text, its box, and its leader line when displaced.
struct PlacedLabel {
  std::vector<std::size_t> anchors;  ///< indices into the input, in sequence order
  std::string text;
  LabelBox box;
  double text_width = 0, text_height = 0;
  bool leader = false;               ///< draw a line from (lx0, ly0) to (lx1, ly1)
  double lx0 = 0, ly0 = 0, lx1 = 0, ly1 = 0;
  bool overlapping = false;          ///< no free place was found
};

struct LabelLayoutResult {
  std::vector<PlacedLabel> labels;  ///< in placement order
  std::size_t merged_anchors = 0;   ///< anchors named by a label with more than one anchor
  std::size_t leaders = 0;
  std::size_t overlaps = 0;         ///< labels that could not be placed clear of everything
};

/// Text size (width, height) in pixels of a label; the renderer passes its font metrics.
using MeasureText = std::function<std::pair<double, double>(const std::string&)>;

/// The merged text for anchors of one group, given their labels in sequence order and their
/// sequence numbers: runs of 3+ consecutive numbers become "first–last", the rest are listed.
std::string mergedLabelText(const std::vector<std::string>& texts, const std::vector<int>& sequence);

/// Lays out the labels of `anchors`. Deterministic: the same input gives the same output.
LabelLayoutResult layoutLabels(const std::vector<LabelAnchor>& anchors, const LabelLayoutParams& params,
                               const MeasureText& measure);

}  // namespace adit::tools
