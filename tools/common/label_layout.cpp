// SPDX-License-Identifier: BSD-3-Clause
#include "common/label_layout.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace adit::tools {

bool LabelBox::touchesDisc(double cx, double cy, double r) const {
  const double nx = std::clamp(cx, x0, x1), ny = std::clamp(cy, y0, y1);
  const double dx = cx - nx, dy = cy - ny;
  return dx * dx + dy * dy < r * r;
}

bool LabelBox::crossesSegment(double ax, double ay, double bx, double by) const {
  // Liang-Barsky clipping against the open box
  double t0 = 0, t1 = 1;
  const double dx = bx - ax, dy = by - ay;
  const double p[4] = {-dx, dx, -dy, dy}, q[4] = {ax - x0, x1 - ax, ay - y0, y1 - ay};
  for (int k = 0; k < 4; ++k) {
    if (p[k] == 0) {
      if (q[k] <= 0) return false;
      continue;
    }
    const double t = q[k] / p[k];
    if (p[k] < 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
  }
  return t1 - t0 > 1e-9;
}

std::string mergedLabelText(const std::vector<std::string>& texts, const std::vector<int>& sequence) {
  std::string out;
  std::size_t i = 0;
  while (i < texts.size()) {
    std::size_t j = i;
    while (j + 1 < texts.size() && sequence[j + 1] == sequence[j] + 1) ++j;
    auto append = [&](const std::string& s) { out += (out.empty() ? "" : ", ") + s; };
    if (j - i >= 2) {
      append(texts[i] + "\u2013" + texts[j]);  // en dash: a run
    } else {
      for (std::size_t k = i; k <= j; ++k) append(texts[k]);
    }
    i = j + 1;
  }
  return out;
}

namespace {

struct Item {
  std::vector<std::size_t> anchors;
  double cx = 0, cy = 0, reach = 0;  ///< a circle holding all its markers
  int priority = 0;
  std::size_t first = 0;             ///< input order of its first anchor, for ties
};

std::size_t findRoot(std::vector<std::size_t>& parent, std::size_t i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

/// The box of a label of size (w, h) whose nearest point to (cx, cy) is `d` away in direction (ux, uy).
LabelBox candidateBox(double cx, double cy, double d, double ux, double uy, double w, double h) {
  const double px = cx + d * ux, py = cy + d * uy;
  LabelBox b;
  b.x0 = ux > 0.1 ? px : ux < -0.1 ? px - w : px - w / 2;
  b.y0 = uy > 0.1 ? py : uy < -0.1 ? py - h : py - h / 2;
  b.x1 = b.x0 + w;
  b.y1 = b.y0 + h;
  return b;
}

}  // namespace

LabelLayoutResult layoutLabels(const std::vector<LabelAnchor>& anchors, const LabelLayoutParams& params,
                               const MeasureText& measure) {
  LabelLayoutResult result;
  const std::size_t n = anchors.size();
  std::vector<std::pair<double, double>> size(n, {0.0, 0.0});
  for (std::size_t i = 0; i < n; ++i)
    if (!anchors[i].text.empty()) size[i] = measure(anchors[i].text);

  // Merge: anchors of one group whose markers are nearer, edge to edge, than a label's size.
  std::vector<std::size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t i = 0; i < n; ++i) {
    const LabelAnchor& a = anchors[i];
    if (a.text.empty() || a.group < 0) continue;
    for (std::size_t j = i + 1; j < n; ++j) {
      const LabelAnchor& b = anchors[j];
      if (b.text.empty() || b.group != a.group) continue;
      const double label = params.merge_factor * std::max({size[i].first, size[i].second, size[j].first, size[j].second});
      if (std::hypot(a.x - b.x, a.y - b.y) < label + a.radius + b.radius)
        parent[findRoot(parent, j)] = findRoot(parent, i);
    }
  }
  std::vector<Item> items;
  std::vector<std::size_t> item_of(n, std::numeric_limits<std::size_t>::max());
  for (std::size_t i = 0; i < n; ++i) {
    if (anchors[i].text.empty()) continue;
    const std::size_t root = findRoot(parent, i);
    if (item_of[root] == std::numeric_limits<std::size_t>::max()) {
      item_of[root] = items.size();
      items.push_back({});
      items.back().first = i;
      items.back().priority = anchors[i].priority;
    }
    Item& it = items[item_of[root]];
    it.anchors.push_back(i);
    it.priority = std::min(it.priority, anchors[i].priority);
  }

  std::vector<PlacedLabel> labels;
  for (Item& it : items) {
    std::stable_sort(it.anchors.begin(), it.anchors.end(),
                     [&](std::size_t a, std::size_t b) { return anchors[a].sequence < anchors[b].sequence; });
    for (std::size_t k : it.anchors) it.cx += anchors[k].x, it.cy += anchors[k].y;
    it.cx /= double(it.anchors.size());
    it.cy /= double(it.anchors.size());
    for (std::size_t k : it.anchors)
      it.reach = std::max(it.reach, std::hypot(anchors[k].x - it.cx, anchors[k].y - it.cy) + anchors[k].radius);
    PlacedLabel p;
    p.anchors = it.anchors;
    if (it.anchors.size() == 1) {
      p.text = anchors[it.anchors[0]].text;
    } else {
      std::vector<std::string> texts;
      std::vector<int> seq;
      for (std::size_t k : it.anchors) texts.push_back(anchors[k].text), seq.push_back(anchors[k].sequence);
      p.text = mergedLabelText(texts, seq);
      result.merged_anchors += it.anchors.size();
    }
    std::tie(p.text_width, p.text_height) = it.anchors.size() == 1 ? size[it.anchors[0]] : measure(p.text);
    labels.push_back(std::move(p));
  }
  std::vector<std::size_t> order(items.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return items[a].priority != items[b].priority ? items[a].priority < items[b].priority : items[a].first < items[b].first;
  });

  // Right-above first (where a reader looks for it), then the other diagonals, then the sides.
  const double s = std::sqrt(0.5);
  const double dirs[8][2] = {{s, -s}, {s, s}, {-s, -s}, {-s, s}, {1, 0}, {-1, 0}, {0, -1}, {0, 1}};
  const LabelBox& area = params.area;
  std::vector<LabelBox> placed;
  auto inflate = [&](LabelBox b) {
    b.x0 -= params.padding_px, b.y0 -= params.padding_px, b.x1 += params.padding_px, b.y1 += params.padding_px;
    return b;
  };
  // How many things a box collides with: placed labels and obstacle markers (0 = free).
  auto conflicts = [&](const LabelBox& b) {
    const LabelBox pb = inflate(b);
    std::size_t c = 0;
    for (const LabelBox& o : placed) c += pb.intersects(o);
    for (const LabelAnchor& a : anchors)
      if (a.obstacle) c += pb.touchesDisc(a.x, a.y, a.radius);
    return c;
  };
  struct Leader {
    double x0, y0, x1, y1;
  };
  std::vector<Leader> leaders;
  // From the nearest of a label's markers' edges to the nearest point of its box.
  auto leaderTo = [&](const PlacedLabel& p, const LabelBox& b) {
    std::size_t near = p.anchors[0];
    double dmin = std::numeric_limits<double>::infinity();
    for (std::size_t k : p.anchors) {
      const double bx = std::clamp(anchors[k].x, b.x0, b.x1), by = std::clamp(anchors[k].y, b.y0, b.y1);
      const double dk = std::hypot(anchors[k].x - bx, anchors[k].y - by);
      if (dk < dmin) dmin = dk, near = k;
    }
    const LabelAnchor& a = anchors[near];
    Leader l{0, 0, std::clamp(a.x, b.x0, b.x1), std::clamp(a.y, b.y0, b.y1)};
    const double len = std::hypot(l.x1 - a.x, l.y1 - a.y);
    const double t = len > 0 ? std::min(1.0, a.radius / len) : 0.0;
    l.x0 = a.x + (l.x1 - a.x) * t;
    l.y0 = a.y + (l.y1 - a.y) * t;
    return l;
  };
  for (std::size_t idx : order) {
    const Item& it = items[idx];
    PlacedLabel& p = labels[idx];
    const double w = p.text_width, h = p.text_height;
    bool found = false;
    std::size_t best_conflicts = std::numeric_limits<std::size_t>::max();
    LabelBox best;
    int best_ring = 0;
    for (int ring = 0; ring < std::max(1, params.rings) && !found; ++ring) {
      const double d = it.reach + params.gap_px + ring * (h + params.gap_px);
      for (const auto& dir : dirs) {
        const LabelBox b = candidateBox(it.cx, it.cy, d, dir[0], dir[1], w, h);
        if (b.x0 < area.x0 || b.y0 < area.y0 || b.x1 > area.x1 || b.y1 > area.y1) continue;
        std::size_t c = conflicts(b);
        const LabelBox padded = inflate(b);
        for (const Leader& l : leaders) c += padded.crossesSegment(l.x0, l.y0, l.x1, l.y1);
        if (ring > 0) {
          const Leader l = leaderTo(p, b);
          for (const LabelBox& o : placed) c += o.crossesSegment(l.x0, l.y0, l.x1, l.y1);
        }
        if (c < best_conflicts) best_conflicts = c, best = b, best_ring = ring;
        if (c == 0) {
          found = true;
          break;
        }
      }
    }
    if (best_conflicts == std::numeric_limits<std::size_t>::max()) {
      // no candidate inside the area at all (a label wider than the area): the first one, clamped
      best = candidateBox(it.cx, it.cy, it.reach + params.gap_px, dirs[0][0], dirs[0][1], w, h);
      const double dx = std::max(area.x0 - best.x0, std::min(0.0, area.x1 - best.x1));
      const double dy = std::max(area.y0 - best.y0, std::min(0.0, area.y1 - best.y1));
      best.x0 += dx, best.x1 += dx, best.y0 += dy, best.y1 += dy;
      best_conflicts = conflicts(best);
      best_ring = 0;
    }
    p.box = best;
    p.overlapping = best_conflicts > 0;
    result.overlaps += p.overlapping;
    placed.push_back(inflate(best));
    if (best_ring > 0) {
      const Leader l = leaderTo(p, best);
      leaders.push_back(l);
      p.lx0 = l.x0, p.ly0 = l.y0, p.lx1 = l.x1, p.ly1 = l.y1;
      p.leader = true;
      ++result.leaders;
    }
  }
  for (std::size_t idx : order) result.labels.push_back(std::move(labels[idx]));
  return result;
}

}  // namespace adit::tools
