// SPDX-License-Identifier: BSD-3-Clause
// layoutLabels: seeded random anchor sets with dense clusters; no label may cover another label or
// any marker, every labelled anchor is named exactly once (alone or merged), labels stay inside the
// area, and the same input gives the same output. Text is measured at a fixed size per character,
// as a monospace font would be, so the geometry is known without Cairo.
#include "common/label_layout.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <string>
#include <vector>

namespace adit::tools {
namespace {

constexpr double kCharW = 8.0, kTextH = 14.0;

std::pair<double, double> measure(const std::string& s) {
  // the en dash of a run is three bytes and one character
  std::size_t chars = 0;
  for (unsigned char c : s) chars += (c & 0xC0) != 0x80;
  return {kCharW * double(chars), kTextH};
}

std::string letter(int i) { return std::string(1, char('A' + i % 26)) + (i >= 26 ? std::to_string(i / 26) : ""); }

/// A path-like chain of break points with dense clusters, plus start and goal and a few
/// unlabelled markers (sub-goals), in a 600 x 400 area.
std::vector<LabelAnchor> randomAnchors(unsigned seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(40, 560), uy(40, 360), jitter(-6, 6);
  std::uniform_int_distribution<int> coin(0, 2);
  std::vector<LabelAnchor> a;
  double x = ux(rng), y = uy(rng);
  for (int i = 0; i < n; ++i) {
    if (coin(rng) == 0) {  // a jump elsewhere, else a point crowding the previous one
      x = ux(rng), y = uy(rng);
    } else {
      x = std::clamp(x + jitter(rng), 10.0, 590.0), y = std::clamp(y + jitter(rng), 10.0, 390.0);
    }
    LabelAnchor b;
    b.x = x, b.y = y, b.radius = 3.5, b.text = letter(i), b.group = 1, b.sequence = i;
    a.push_back(b);
  }
  for (int k = 0; k < 2; ++k) {
    LabelAnchor s;
    s.x = a[k == 0 ? 0 : n - 1].x + 4, s.y = a[k == 0 ? 0 : n - 1].y + 3, s.radius = 5;
    s.text = k == 0 ? "start" : "goal";
    s.priority = 0;
    a.push_back(s);
  }
  for (int k = 0; k < 5; ++k) {
    LabelAnchor m;
    m.x = ux(rng), m.y = uy(rng), m.radius = 2.5;
    a.push_back(m);
  }
  return a;
}

LabelLayoutParams params() {
  LabelLayoutParams p;
  p.area = {0, 0, 600, 400};
  return p;
}

void expectClean(const std::vector<LabelAnchor>& anchors, const LabelLayoutResult& r, const LabelLayoutParams& p) {
  ASSERT_EQ(r.overlaps, 0u);
  std::multiset<std::size_t> named;
  for (std::size_t i = 0; i < r.labels.size(); ++i) {
    const LabelBox& b = r.labels[i].box;
    EXPECT_GE(b.x0, p.area.x0);
    EXPECT_GE(b.y0, p.area.y0);
    EXPECT_LE(b.x1, p.area.x1);
    EXPECT_LE(b.y1, p.area.y1);
    for (std::size_t j = i + 1; j < r.labels.size(); ++j)
      EXPECT_FALSE(b.intersects(r.labels[j].box)) << r.labels[i].text << " over " << r.labels[j].text;
    for (std::size_t j = 0; j < r.labels.size(); ++j) {
      const PlacedLabel& o = r.labels[j];
      if (j != i && o.leader) {
        EXPECT_FALSE(b.crossesSegment(o.lx0, o.ly0, o.lx1, o.ly1)) << o.text << "'s leader crosses " << r.labels[i].text;
      }
    }
    for (const LabelAnchor& a : anchors)
      EXPECT_FALSE(b.touchesDisc(a.x, a.y, a.radius)) << r.labels[i].text << " over the marker at " << a.x << "," << a.y;
    named.insert(r.labels[i].anchors.begin(), r.labels[i].anchors.end());
  }
  for (std::size_t i = 0; i < anchors.size(); ++i)
    EXPECT_EQ(named.count(i), anchors[i].text.empty() ? 0u : 1u) << "anchor " << i;
}

TEST(LabelLayoutTest, RandomClustersGetLabelsThatOverlapNothing) {
  std::size_t merged = 0, leaders = 0;
  for (unsigned seed = 1; seed <= 200; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const std::vector<LabelAnchor> anchors = randomAnchors(seed, 30);
    const LabelLayoutResult r = layoutLabels(anchors, params(), measure);
    expectClean(anchors, r, params());
    if (HasFatalFailure()) return;
    merged += r.merged_anchors;
    leaders += r.leaders;
  }
  // the clusters are dense enough to exercise merging and leader lines
  EXPECT_GT(merged, 0u);
  EXPECT_GT(leaders, 0u);
}

TEST(LabelLayoutTest, SameInputSameOutput) {
  const std::vector<LabelAnchor> anchors = randomAnchors(7, 40);
  const LabelLayoutResult a = layoutLabels(anchors, params(), measure);
  const LabelLayoutResult b = layoutLabels(anchors, params(), measure);
  ASSERT_EQ(a.labels.size(), b.labels.size());
  for (std::size_t i = 0; i < a.labels.size(); ++i) {
    EXPECT_EQ(a.labels[i].text, b.labels[i].text);
    EXPECT_EQ(a.labels[i].anchors, b.labels[i].anchors);
    EXPECT_EQ(a.labels[i].box.x0, b.labels[i].box.x0);
    EXPECT_EQ(a.labels[i].box.y0, b.labels[i].box.y0);
    EXPECT_EQ(a.labels[i].leader, b.labels[i].leader);
  }
}

TEST(LabelLayoutTest, CloseBreakPointsMergeAndRunsAreShortened) {
  // H and I 1.1 m apart at 3.3 px/m: one label "H, I"; J, K, L in a row: "J–L"; M alone.
  std::vector<LabelAnchor> a;
  auto add = [&](double x, double y, const std::string& t, int seq) {
    LabelAnchor b;
    b.x = x, b.y = y, b.radius = 3.5, b.text = t, b.group = 1, b.sequence = seq;
    a.push_back(b);
  };
  add(100, 100, "H", 7);
  add(103.6, 100, "I", 8);
  add(300, 200, "J", 9);
  add(305, 204, "K", 10);
  add(310, 200, "L", 11);
  add(500, 300, "M", 12);
  const LabelLayoutResult r = layoutLabels(a, params(), measure);
  expectClean(a, r, params());
  std::set<std::string> texts;
  for (const PlacedLabel& p : r.labels) texts.insert(p.text);
  EXPECT_EQ(texts, (std::set<std::string>{"H, I", "J\u2013L", "M"}));
  EXPECT_EQ(r.merged_anchors, 5u);
}

TEST(LabelLayoutTest, MergedTextListsPairsAndShortensRuns) {
  EXPECT_EQ(mergedLabelText({"A"}, {0}), "A");
  EXPECT_EQ(mergedLabelText({"A", "B"}, {0, 1}), "A, B");
  EXPECT_EQ(mergedLabelText({"A", "B", "C", "E"}, {0, 1, 2, 4}), "A\u2013C, E");
  EXPECT_EQ(mergedLabelText({"A", "C", "D", "E", "F"}, {0, 2, 3, 4, 5}), "A, C\u2013F");
}

TEST(LabelLayoutTest, GroupsAndPriorityZeroNeverMerge) {
  // start sits on break point A: two labels, start placed first at its preferred place (right, above)
  std::vector<LabelAnchor> a(2);
  a[0].x = 200, a[0].y = 200, a[0].radius = 3.5, a[0].text = "A", a[0].group = 1;
  a[1].x = 202, a[1].y = 201, a[1].radius = 5, a[1].text = "start", a[1].priority = 0;
  const LabelLayoutResult r = layoutLabels(a, params(), measure);
  expectClean(a, r, params());
  ASSERT_EQ(r.labels.size(), 2u);
  EXPECT_EQ(r.labels[0].text, "start");
  EXPECT_GT(r.labels[0].box.x0, a[1].x);
  EXPECT_LT(r.labels[0].box.y1, a[1].y);
  EXPECT_EQ(r.merged_anchors, 0u);
}

TEST(LabelLayoutTest, LabelsAtTheEdgeStayInside) {
  // a marker in each corner: the preferred place (right, above) is outside for three of them
  std::vector<LabelAnchor> a(4);
  const double xs[] = {4, 596, 4, 596}, ys[] = {4, 4, 396, 396};
  for (int i = 0; i < 4; ++i) a[i].x = xs[i], a[i].y = ys[i], a[i].radius = 4, a[i].text = "start";
  const LabelLayoutResult r = layoutLabels(a, params(), measure);
  expectClean(a, r, params());
  EXPECT_EQ(r.leaders, 0u);  // a first-ring place exists in every corner
}

TEST(LabelLayoutTest, DisplacedLabelsGetALeaderFromTheMarkerEdge) {
  // a marker boxed in by a ring of unlabelled markers: its label must go beyond the first ring
  std::vector<LabelAnchor> a(1);
  a[0].x = 300, a[0].y = 200, a[0].radius = 3.5, a[0].text = "Q";
  for (int k = 0; k < 24; ++k) {
    LabelAnchor m;
    m.x = 300 + 14 * std::cos(k * M_PI / 12), m.y = 200 + 14 * std::sin(k * M_PI / 12), m.radius = 3;
    a.push_back(m);
  }
  const LabelLayoutResult r = layoutLabels(a, params(), measure);
  expectClean(a, r, params());
  ASSERT_EQ(r.labels.size(), 1u);
  const PlacedLabel& p = r.labels[0];
  ASSERT_TRUE(p.leader);
  EXPECT_NEAR(std::hypot(p.lx0 - 300, p.ly0 - 200), 3.5, 1e-9);  // starts on the marker's edge
  EXPECT_TRUE(p.lx1 >= p.box.x0 && p.lx1 <= p.box.x1 && p.ly1 >= p.box.y0 && p.ly1 <= p.box.y1);
}

TEST(LabelLayoutTest, SegmentCrossingTheBox) {
  const LabelBox b{10, 10, 20, 20};
  EXPECT_TRUE(b.crossesSegment(0, 15, 30, 15));
  EXPECT_TRUE(b.crossesSegment(12, 12, 14, 14));  // inside
  EXPECT_FALSE(b.crossesSegment(0, 0, 30, 5));
  EXPECT_FALSE(b.crossesSegment(0, 10, 30, 10));  // along an edge: not through the interior
  EXPECT_FALSE(b.crossesSegment(0, 0, 9, 30));
}

TEST(LabelLayoutTest, NoRoomIsCountedNotHidden) {
  // an area smaller than the label: placed clamped, reported as overlapping
  std::vector<LabelAnchor> a(1);
  a[0].x = 5, a[0].y = 5, a[0].radius = 3, a[0].text = "a long label";
  LabelLayoutParams p;
  p.area = {0, 0, 20, 20};
  const LabelLayoutResult r = layoutLabels(a, p, measure);
  ASSERT_EQ(r.labels.size(), 1u);
  EXPECT_EQ(r.overlaps, 1u);
  EXPECT_TRUE(r.labels[0].overlapping);
}

}  // namespace
}  // namespace adit::tools
