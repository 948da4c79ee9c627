// SPDX-License-Identifier: BSD-3-Clause
// Top-view pictures: one pass over the octree leaves into a 32-bit raster (per pixel the lowest
// floor key, or the strongest slice state), coloured in place, then annotated with Cairo.
#include "common/render_topview.hpp"

#include <cairo-svg.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>
#include <sstream>
#include <vector>

#include "adit/map/map_io.hpp"

namespace adit::tools {
namespace {

using map::Aabb;
using map::OccupancyMap;
using adit::Status;
using map::Vec3;
using map::VoxelState;

// ---- Cairo handles ----------------------------------------------------------------------------

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* c) const { cairo_destroy(c); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

Status cairoFailure(const std::string& path, const char* what, cairo_status_t st) {
  return adit::internalError(path + ": Cairo could not " + what + ": " + cairo_status_to_string(st) +
                            "; nothing was written");
}

// ---- colours ------------------------------------------------------------------------------------

constexpr std::uint32_t kPage = 0xFFFFFF;
constexpr std::uint32_t kInk = 0x1A1A1A;
constexpr std::uint32_t kMutedInk = 0x4A4A4A;
constexpr std::uint32_t kFrame = 0x333333;

// Viridis (matplotlib, BSD/CC0) sampled at t = 0, 0.1, ..., 1. The darkest tenth is skipped so
// that the lowest floor still stands out against the dark background.
constexpr std::array<std::uint32_t, 11> kViridis = {0x440154, 0x482475, 0x414487, 0x355F8D,
                                                    0x2A788E, 0x21918C, 0x22A884, 0x44BF70,
                                                    0x7AD151, 0xBDDF26, 0xFDE725};
constexpr double kRampStart = 0.15;

std::uint32_t rampColour(double t) {
  const double v = kRampStart + (1.0 - kRampStart) * std::clamp(t, 0.0, 1.0);
  const double f = v * 10.0;
  const int i = std::min(static_cast<int>(f), 9);
  const double a = f - i;
  std::uint32_t out = 0;
  for (int shift = 16; shift >= 0; shift -= 8) {
    const double c0 = (kViridis[i] >> shift) & 0xFF, c1 = (kViridis[i + 1] >> shift) & 0xFF;
    out |= static_cast<std::uint32_t>(std::lround(c0 + a * (c1 - c0))) << shift;
  }
  return out;
}

void setColour(cairo_t* cr, std::uint32_t c, double alpha = 1.0) {
  cairo_set_source_rgba(cr, ((c >> 16) & 0xFF) / 255.0, ((c >> 8) & 0xFF) / 255.0, (c & 0xFF) / 255.0, alpha);
}

// ---- numbers --------------------------------------------------------------------------------------

/// Smallest 1/2/5 x 10^k >= x (x > 0).
double niceAtLeast(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= x * (1 - 1e-9)) return m * p;
  return 10.0 * p;
}
/// Largest 1/2/5 x 10^k <= x (x > 0).
double niceAtMost(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= x * (1 + 1e-9)) return m * p;
  return p;
}
double nextNice(double step) { return niceAtLeast(step * 1.5); }

/// Decimals that print `step` (and its multiples) exactly, at most 3.
int decimalsFor(double step) {
  for (int d = 0; d < 3; ++d) {
    const double scaled = step * std::pow(10.0, d);
    if (std::abs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, scaled)) return d;
  }
  return 3;
}

/// Fixed-point with a typographic minus and no "-0".
std::string formatNumber(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s[0] == '-') {
    if (s.find_first_not_of("-0.") == std::string::npos) return s.substr(1);
    return "\u2212" + s.substr(1);
  }
  return s;
}

std::string formatLength(double m) {
  if (m >= 1000.0) return formatNumber(m / 1000.0, decimalsFor(m / 1000.0)) + " km";
  return formatNumber(m, decimalsFor(m)) + " m";
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// ---- text ---------------------------------------------------------------------------------------

struct Font {
  double size = 12.0;
  bool bold = false;
};

void useFont(cairo_t* cr, const Font& f) {
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL,
                         f.bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, f.size);
}

/// Same metrics on every surface: no hinting of metrics, so layout measured once holds for PNG
/// and SVG alike.
void setupText(cairo_t* cr) {
  cairo_font_options_t* fo = cairo_font_options_create();
  cairo_font_options_set_hint_metrics(fo, CAIRO_HINT_METRICS_OFF);
  cairo_font_options_set_hint_style(fo, CAIRO_HINT_STYLE_SLIGHT);
  cairo_font_options_set_antialias(fo, CAIRO_ANTIALIAS_GRAY);
  cairo_set_font_options(cr, fo);
  cairo_font_options_destroy(fo);
}

double textWidth(cairo_t* cr, const Font& f, const std::string& s) {
  useFont(cr, f);
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  return e.x_advance;
}

struct LineMetrics {
  double ascent = 0, descent = 0;
  double height() const { return ascent + descent; }
};

LineMetrics lineMetrics(cairo_t* cr, const Font& f) {
  useFont(cr, f);
  cairo_font_extents_t e;
  cairo_font_extents(cr, &e);
  return {e.ascent, e.descent};
}

/// Draws `s` with its baseline at y; align 0 = left, 0.5 = centre, 1 = right of x.
void drawText(cairo_t* cr, const Font& f, std::uint32_t colour, const std::string& s, double x, double y,
              double align = 0.0) {
  useFont(cr, f);
  cairo_text_extents_t e;
  cairo_text_extents(cr, s.c_str(), &e);
  setColour(cr, colour);
  cairo_move_to(cr, x - align * e.x_advance, y);
  cairo_show_text(cr, s.c_str());
  cairo_new_path(cr);
}

// ---- layout -------------------------------------------------------------------------------------

struct Ticks {
  double step = 1.0;
  int decimals = 0;
  std::vector<double> values;
  std::vector<std::string> labels;
  double max_label_width = 0.0;
};

Ticks makeTicks(cairo_t* cr, const Font& f, double lo, double hi, double step) {
  Ticks t;
  t.step = step;
  t.decimals = decimalsFor(step);
  const long long first = std::llround(std::ceil(lo / step - 1e-9)), last = std::llround(std::floor(hi / step + 1e-9));
  for (long long k = first; k <= last; ++k) {
    const double v = k * step;
    t.values.push_back(v);
    t.labels.push_back(formatNumber(v, t.decimals));
    t.max_label_width = std::max(t.max_label_width, textWidth(cr, f, t.labels.back()));
  }
  return t;
}

struct Layout {
  double u = 1.0;  ///< annotation scale (1 = sizes below in pixels)
  int width = 0, height = 0;
  double s = 1.0;  ///< pixels per metre
  int map_left = 0, map_top = 0, mw = 0, mh = 0;
  double x0 = 0, y1 = 0;  ///< world coordinates of the map area's left and top edges
  bool slice = false;

  Font title_font, caption_font, tick_font, legend_title_font, legend_font, north_font;
  std::string title, caption;
  double title_base = 0, caption_base = 0, margin = 0;

  Ticks xt, yt;
  double tick_len = 0, xlabel_base = 0, ylabel_right = 0;

  double panel_left = 0, panel_top = 0;
  double north_cx = 0, north_base = 0, arrow_top = 0, arrow_bottom = 0, arrow_half = 0;
  double legend_top = 0;

  // projection legend
  std::string legend_title;
  std::vector<std::string> legend_subtitle;
  std::optional<double> fmin, fmax;  ///< elevation range of the ramp
  int elev_decimals = 1;
  std::vector<double> ramp_ticks;    ///< elevations labelled on the ramp (ends included)
  double ramp_width = 0, ramp_height = 0, swatch_w = 0, swatch_h = 0, row_h = 0;

  // scale bar
  double bar_m = 0, bar_px = 0, bar_left = 0, bar_top = 0, bar_h = 0, bar_label_base = 0;
  int bar_segments = 4;
};

struct RasterStats {
  std::uint32_t kmin = std::numeric_limits<std::uint32_t>::max(), kmax = 0;
  std::uint64_t free_pixels = 0;
};

double rampStep(double fmin, double fmax) { return niceAtLeast((fmax - fmin) / 6.0); }

/// Projection legend entries (ramp ticks) between fmin and fmax, spaced at least `min_gap` px on a
/// ramp `height` px tall.
std::vector<double> rampTicks(double fmin, double fmax, double height, double min_gap) {
  std::vector<double> t{fmax};
  if (fmax - fmin <= 0) return t;
  const double step = rampStep(fmin, fmax);
  for (long long k = std::llround(std::floor(fmax / step)); k * step > fmin; --k) {
    const double v = k * step;
    const double px_top = (fmax - v) / (fmax - fmin) * height;
    const double px_bottom = (v - fmin) / (fmax - fmin) * height;
    if (px_top >= min_gap && px_bottom >= min_gap) t.push_back(v);
  }
  t.push_back(fmin);
  return t;
}

std::string legendLabel(const Layout& L, double v) { return formatNumber(v, L.elev_decimals) + " m"; }

/// Width and height of the legend block (title, ramp or swatches).
std::pair<double, double> legendSize(cairo_t* cr, const Layout& L) {
  const double u = L.u;
  double w = textWidth(cr, L.legend_title_font, L.legend_title);
  double h = lineMetrics(cr, L.legend_title_font).height();
  for (const std::string& line : L.legend_subtitle) {
    w = std::max(w, textWidth(cr, L.legend_font, line));
    h += lineMetrics(cr, L.legend_font).height();
  }
  h += 10 * u;
  const double swatch_row = L.swatch_w + 8 * u;
  if (!L.slice) {
    if (L.fmin && *L.fmax > *L.fmin) {
      double lw = 0;
      for (double v : L.ramp_ticks) lw = std::max(lw, textWidth(cr, L.legend_font, legendLabel(L, v)));
      w = std::max(w, L.ramp_width + 10 * u + lw);
      h += L.ramp_height + 24 * u;
    } else if (L.fmin) {  // one floor level: a swatch instead of a ramp
      w = std::max(w, swatch_row + textWidth(cr, L.legend_font, legendLabel(L, *L.fmin)));
      h += L.row_h;
    }
    w = std::max(w, swatch_row + textWidth(cr, L.legend_font, L.fmin ? "Rock / unknown" : "No free space"));
    h += L.row_h;
  } else {
    for (const char* s : {"Free", "Occupied (rock)", "Unknown"})
      w = std::max(w, swatch_row + textWidth(cr, L.legend_font, s));
    h += 3 * L.row_h;
  }
  return {w, h};
}

Status computeLayout(const OccupancyMap& map, const TopViewOptions& o, cairo_t* cr, Layout& L, bool& raised,
                     const RasterStats* stats) {
  const Aabb b = map.bounds();
  const double wx = b.max.x() - b.min.x(), wy = b.max.y() - b.min.y();
  raised = false;
  double s = o.pixels_per_m;
  if (s <= 0) {
    s = o.max_pixels / std::max(wx, wy);
    const double min_s = 3.0 / o.min_roadway_width_m;
    if (s < min_s) {
      s = min_s;
      raised = true;
    }
  }
  L.s = s;
  L.slice = o.slice_z_m.has_value();
  L.x0 = b.min.x();
  L.y1 = b.max.y();
  const double mw = std::max(1.0, std::ceil(wx * s - 1e-6)), mh = std::max(1.0, std::ceil(wy * s - 1e-6));
  const double cap_px = o.max_megapixels * 1e6;
  auto tooLarge = [&](double w, double h) {
    std::ostringstream os;
    os.precision(3);
    os << "the picture would be " << std::llround(w) << " x " << std::llround(h) << " px ("
       << w * h / 1e6 << " Mpx) for a map of " << wx << " x " << wy << " m at " << s << " px/m";
    if (raised)
      os << " (the smallest scale that keeps a " << o.min_roadway_width_m << " m roadway 3 px wide)";
    os << ", over the cap of " << o.max_megapixels << " Mpx and 32767 px a side";
    os << (raised || o.pixels_per_m > 0 ? "; choose a smaller pixels_per_m explicitly"
                                        : "; lower max_pixels");
    return adit::outOfRange(os.str());
  };
  if (mw > 32000 || mh > 32000 || mw * mh > cap_px) return tooLarge(mw, mh);
  L.mw = static_cast<int>(mw);
  L.mh = static_cast<int>(mh);

  const double u = std::clamp(std::max(mw, mh) / 1000.0, 1.0, 4.0);
  L.u = u;
  L.margin = 22 * u;
  L.title_font = {21 * u, true};
  L.caption_font = {12.5 * u, false};
  L.tick_font = {11 * u, false};
  L.legend_title_font = {13 * u, true};
  L.legend_font = {12 * u, false};
  L.north_font = {16 * u, true};
  L.tick_len = 5 * u;
  L.swatch_w = 18 * u;
  L.swatch_h = 12 * u;
  L.row_h = 20 * u;
  L.ramp_width = 18 * u;
  L.ramp_height = 200 * u;

  // Title and caption.
  L.title = o.title;
  const double res = map.resolution();
  {
    const int d = decimalsFor(res);
    const int de = std::max(1, std::min(d, 2));
    std::ostringstream os;
    os << "Resolution " << formatNumber(res, d) << " m  \u00b7  extent " << formatNumber(wx, de) << " \u00d7 "
       << formatNumber(wy, de) << " m, z " << formatNumber(b.min.z(), de) << " to " << formatNumber(b.max.z(), de)
       << " m  \u00b7  "
       << (s >= 1 ? formatNumber(s, s >= 10 ? 1 : 2) + " px/m" : "1 px = " + formatNumber(1 / s, 2) + " m")
       << "  \u00b7  coordinates in m, x east, y north";
    L.caption = os.str();
  }

  // Legend contents.
  if (L.slice) {
    L.legend_title = "Slice at z = " + formatNumber(*o.slice_z_m, 2) + " m";
    if (o.slice_band_m > 0) L.legend_subtitle = {"band \u00b1" + formatNumber(o.slice_band_m / 2, 2) + " m"};
  } else {
    L.legend_title = "Floor elevation";
    L.legend_subtitle = {"lowest free voxel"};
    // Before the raster exists, the map's height range stands in for the floor range, so that
    // the final layout almost always has the same geometry.
    if (!stats || stats->free_pixels > 0) {
      L.fmin = stats ? b.min.z() + stats->kmin * res : b.min.z();
      L.fmax = stats ? b.min.z() + stats->kmax * res : b.max.z();
      const double gap = 1.4 * lineMetrics(cr, L.legend_font).height();
      L.ramp_ticks = rampTicks(*L.fmin, *L.fmax, L.ramp_height, gap);
      const double step = *L.fmax > *L.fmin ? rampStep(*L.fmin, *L.fmax) : res;
      L.elev_decimals = std::min(2, std::max(decimalsFor(res), decimalsFor(step)));
    }
  }
  const auto [legend_w, legend_h] = legendSize(cr, L);

  // Axis ticks: nice steps whose labels do not touch.
  double xstep = niceAtLeast(std::max(70 * u / s, 1e-3));
  for (;;) {
    L.xt = makeTicks(cr, L.tick_font, b.min.x(), b.max.x(), xstep);
    if (xstep * s >= L.xt.max_label_width + 18 * u) break;
    xstep = nextNice(xstep);
  }
  const LineMetrics tick_m = lineMetrics(cr, L.tick_font);
  double ystep = niceAtLeast(std::max(std::max(55 * u, 2.5 * tick_m.height()) / s, 1e-3));
  L.yt = makeTicks(cr, L.tick_font, b.min.y(), b.max.y(), ystep);

  // Horizontal placement.
  const double M = L.margin;
  L.map_left = static_cast<int>(std::ceil(std::max(M + L.yt.max_label_width + L.tick_len + 5 * u,
                                                   M + L.xt.max_label_width / 2)));
  L.ylabel_right = L.map_left - L.tick_len - 4 * u;
  const double panel_gap = std::max(30 * u, L.xt.max_label_width / 2 + 12 * u);
  L.panel_left = L.map_left + L.mw + panel_gap;

  // North arrow block.
  const LineMetrics north_m = lineMetrics(cr, L.north_font);
  L.arrow_half = 10 * u;
  const double panel_w = std::max(legend_w, 2 * L.arrow_half);
  L.north_cx = L.panel_left + L.arrow_half;
  const double panel_h_north = north_m.height() + 4 * u + 46 * u;

  // Vertical placement.
  double y = M;
  if (!L.title.empty()) {
    const LineMetrics tm = lineMetrics(cr, L.title_font);
    L.title_base = y + tm.ascent;
    y += tm.height() + 4 * u;
  }
  const LineMetrics cm = lineMetrics(cr, L.caption_font);
  L.caption_base = y + cm.ascent;
  y += cm.height() + 18 * u;
  L.map_top = static_cast<int>(std::ceil(y));
  L.panel_top = L.map_top;
  L.north_base = L.panel_top + north_m.ascent;
  L.arrow_top = L.panel_top + north_m.height() + 4 * u;
  L.arrow_bottom = L.arrow_top + 46 * u;
  L.legend_top = L.panel_top + panel_h_north + 30 * u;
  const double panel_bottom = L.legend_top + legend_h;

  L.xlabel_base = L.map_top + L.mh + L.tick_len + 4 * u + tick_m.ascent;

  // Scale bar: the round length nearest (in ratio) to a quarter of the map width, never over 40 %
  // of it unless the map is tiny.
  const double target_m = std::clamp(0.25 * L.mw, 110 * u, 420 * u) / s;
  const double lo_m = niceAtMost(target_m), hi_m = niceAtLeast(target_m);
  const bool hi_fits = hi_m * s <= std::max(0.4 * L.mw, 110 * u);
  L.bar_m = hi_fits && hi_m / target_m < target_m / lo_m ? hi_m : lo_m;
  L.bar_px = L.bar_m * s;
  const double lead = L.bar_m / std::pow(10.0, std::floor(std::log10(L.bar_m) + 1e-9));
  L.bar_segments = std::lround(lead) == 5 ? 5 : 4;
  L.bar_left = L.map_left;
  L.bar_top = L.xlabel_base + tick_m.descent + 20 * u;
  L.bar_h = 7 * u;
  const LineMetrics lm = lineMetrics(cr, L.legend_font);
  L.bar_label_base = L.bar_top + L.bar_h + 5 * u + lm.ascent;
  const double bar_bottom = L.bar_label_base + lm.descent;

  double right = std::max({L.map_left + L.mw + L.xt.max_label_width / 2, L.panel_left + panel_w,
                           L.bar_left + L.bar_px + textWidth(cr, L.legend_font, formatLength(L.bar_m)) / 2});
  right = std::max({right, M + (L.title.empty() ? 0.0 : textWidth(cr, L.title_font, L.title)),
                    M + textWidth(cr, L.caption_font, L.caption)});
  const double W = std::ceil(right + M), H = std::ceil(std::max(bar_bottom, panel_bottom) + M);
  if (W > 32000 || H > 32000 || W * H > cap_px) return tooLarge(W, H);
  L.width = static_cast<int>(W);
  L.height = static_cast<int>(H);
  return {};
}

// ---- raster ---------------------------------------------------------------------------------------

constexpr std::uint32_t kNoFloor = std::numeric_limits<std::uint32_t>::max();
enum : std::uint32_t { kSliceUnknown = 0, kSliceOccupied = 1, kSliceFree = 2 };

/// Fills the map area (mw x mh slots of `stride` uint32 per row starting at `base`) with per-pixel
/// values, then turns them into colours in place.
RasterStats rasterise(const OccupancyMap& map, const TopViewOptions& o, const Layout& L, std::uint32_t* base,
                      std::size_t stride) {
  const Aabb b = map.bounds();
  const double res = map.resolution(), s = L.s;
  const bool slice = o.slice_z_m.has_value();
  const double zlo = slice ? *o.slice_z_m - o.slice_band_m / 2 : 0.0;
  const double zhi = slice ? *o.slice_z_m + o.slice_band_m / 2 : 0.0;
  const std::uint32_t init = slice ? kSliceUnknown : kNoFloor;
  for (int r = 0; r < L.mh; ++r) std::fill_n(base + r * stride, L.mw, init);

  constexpr double eps = 1e-6;
  map.forEachLeaf([&](const Vec3& c, double size, VoxelState state) {
    const double h = 0.5 * size;
    if (slice) {
      if (c.z() - h > zhi || c.z() + h <= zlo) return;  // voxel [z-h, z+h) does not meet the band
    } else if (state != VoxelState::kFree) {
      return;
    }
    const int i0 = std::max(0, static_cast<int>(std::floor((c.x() - h - L.x0) * s + eps)));
    const int i1 = std::min(L.mw, std::max(i0 + 1, static_cast<int>(std::ceil((c.x() + h - L.x0) * s - eps))));
    const int r0 = std::max(0, static_cast<int>(std::floor((L.y1 - c.y() - h) * s + eps)));
    const int r1 = std::min(L.mh, std::max(r0 + 1, static_cast<int>(std::ceil((L.y1 - c.y() + h) * s - eps))));
    if (slice) {
      const std::uint32_t v = state == VoxelState::kFree ? kSliceFree : kSliceOccupied;
      for (int r = r0; r < r1; ++r) {
        std::uint32_t* row = base + r * stride;
        for (int i = i0; i < i1; ++i) row[i] = std::max(row[i], v);
      }
    } else {
      const double kf = std::round((c.z() - h - b.min.z()) / res);
      const std::uint32_t k = static_cast<std::uint32_t>(std::max(0.0, kf));
      for (int r = r0; r < r1; ++r) {
        std::uint32_t* row = base + r * stride;
        for (int i = i0; i < i1; ++i) row[i] = std::min(row[i], k);
      }
    }
  });

  RasterStats st;
  for (int r = 0; r < L.mh; ++r) {
    const std::uint32_t* row = base + r * stride;
    for (int i = 0; i < L.mw; ++i) {
      if (slice ? row[i] == kSliceFree : row[i] != kNoFloor) {
        ++st.free_pixels;
        if (!slice) {
          st.kmin = std::min(st.kmin, row[i]);
          st.kmax = std::max(st.kmax, row[i]);
        }
      }
    }
  }
  // Colours (CAIRO_FORMAT_RGB24: 0x00RRGGBB in native order).
  std::array<std::uint32_t, 256> lut{};
  for (int j = 0; j < 256; ++j) lut[j] = rampColour(j / 255.0);
  const double span = st.kmax > st.kmin ? double(st.kmax - st.kmin) : 0.0;
  for (int r = 0; r < L.mh; ++r) {
    std::uint32_t* row = base + r * stride;
    for (int i = 0; i < L.mw; ++i) {
      std::uint32_t& p = row[i];
      if (slice) {
        p = p == kSliceFree ? kTopViewSliceFree : p == kSliceOccupied ? kTopViewSliceOccupied : kTopViewBackground;
      } else if (p == kNoFloor) {
        p = kTopViewBackground;
      } else {
        const int j = span > 0 ? static_cast<int>(std::lround((p - st.kmin) / span * 255.0)) : 128;
        p = lut[std::clamp(j, 0, 255)];
      }
    }
  }
  return st;
}

// ---- annotations ----------------------------------------------------------------------------------

void drawNorthArrow(cairo_t* cr, const Layout& L) {
  const double cx = L.north_cx, top = L.arrow_top, bottom = L.arrow_bottom, hw = L.arrow_half;
  const double notch = bottom - 0.28 * (bottom - top);
  drawText(cr, L.north_font, kInk, "N", cx, L.north_base, 0.5);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_MITER);
  // left half dark, right half light: the classic two-tone arrowhead
  cairo_move_to(cr, cx, top);
  cairo_line_to(cr, cx - hw, bottom);
  cairo_line_to(cr, cx, notch);
  cairo_close_path(cr);
  setColour(cr, kInk);
  cairo_fill(cr);
  cairo_move_to(cr, cx, top);
  cairo_line_to(cr, cx + hw, bottom);
  cairo_line_to(cr, cx, notch);
  cairo_close_path(cr);
  setColour(cr, kPage);
  cairo_fill_preserve(cr);
  setColour(cr, kInk);
  cairo_set_line_width(cr, 1.2 * L.u);
  cairo_stroke(cr);
  cairo_move_to(cr, cx, top);
  cairo_line_to(cr, cx - hw, bottom);
  cairo_line_to(cr, cx, notch);
  cairo_close_path(cr);
  cairo_stroke(cr);
}

void drawSwatch(cairo_t* cr, const Layout& L, double x, double y_top, std::uint32_t colour,
                const std::string& label) {
  cairo_rectangle(cr, x, y_top, L.swatch_w, L.swatch_h);
  setColour(cr, colour);
  cairo_fill_preserve(cr);
  setColour(cr, kFrame);
  cairo_set_line_width(cr, 1.0 * L.u);
  cairo_stroke(cr);
  // centre the digits' middle on the swatch
  const double base = y_top + L.swatch_h / 2 + 0.36 * L.legend_font.size;
  drawText(cr, L.legend_font, kInk, label, x + L.swatch_w + 8 * L.u, base);
}

void drawLegend(cairo_t* cr, const Layout& L) {
  const double u = L.u, x = L.panel_left;
  double y = L.legend_top;
  const LineMetrics tm = lineMetrics(cr, L.legend_title_font), lm = lineMetrics(cr, L.legend_font);
  drawText(cr, L.legend_title_font, kInk, L.legend_title, x, y + tm.ascent);
  y += tm.height();
  for (const std::string& line : L.legend_subtitle) {
    drawText(cr, L.legend_font, kMutedInk, line, x, y + lm.ascent);
    y += lm.height();
  }
  y += 10 * u;
  if (L.slice) {
    drawSwatch(cr, L, x, y, kTopViewSliceFree, "Free");
    drawSwatch(cr, L, x, y + L.row_h, kTopViewSliceOccupied, "Occupied (rock)");
    drawSwatch(cr, L, x, y + 2 * L.row_h, kTopViewBackground, "Unknown");
    return;
  }
  if (L.fmin && *L.fmax > *L.fmin) {
    const double top = y + 4 * u, h = L.ramp_height, w = L.ramp_width;
    const double fmin = *L.fmin, fmax = *L.fmax, span = fmax - fmin;
    // the ramp as a gradient (top = highest floor), so SVG keeps it as one element
    cairo_pattern_t* ramp = cairo_pattern_create_linear(0, top + h, 0, top);
    constexpr int kStops = 40;
    for (int k = 0; k <= kStops; ++k) {
      const std::uint32_t c = rampColour(double(k) / kStops);
      cairo_pattern_add_color_stop_rgb(ramp, double(k) / kStops, ((c >> 16) & 0xFF) / 255.0,
                                       ((c >> 8) & 0xFF) / 255.0, (c & 0xFF) / 255.0);
    }
    cairo_rectangle(cr, x, top, w, h);
    cairo_set_source(cr, ramp);
    cairo_fill(cr);
    cairo_pattern_destroy(ramp);
    cairo_rectangle(cr, x, top, w, h);
    setColour(cr, kFrame);
    cairo_set_line_width(cr, 1.0 * u);
    cairo_stroke(cr);
    for (double v : L.ramp_ticks) {
      const double ty = top + (fmax - v) / span * h;
      cairo_move_to(cr, x + w, ty);
      cairo_line_to(cr, x + w + 5 * u, ty);
      setColour(cr, kFrame);
      cairo_stroke(cr);
      drawText(cr, L.legend_font, kInk, legendLabel(L, v), x + w + 9 * u, ty + 0.36 * L.legend_font.size);
    }
    y = top + h + 20 * u;
  } else if (L.fmin) {
    drawSwatch(cr, L, x, y, rampColour(0.5), legendLabel(L, *L.fmin));
    y += L.row_h;
  }
  drawSwatch(cr, L, x, y, kTopViewBackground, L.fmin ? "Rock / unknown" : "No free space");
}

void drawScaleBar(cairo_t* cr, const Layout& L) {
  const double u = L.u, seg = L.bar_px / L.bar_segments;
  for (int k = 0; k < L.bar_segments; ++k) {
    cairo_rectangle(cr, L.bar_left + k * seg, L.bar_top, seg, L.bar_h);
    setColour(cr, k % 2 == 0 ? kInk : kPage);
    cairo_fill(cr);
  }
  cairo_rectangle(cr, L.bar_left, L.bar_top, L.bar_px, L.bar_h);
  setColour(cr, kInk);
  cairo_set_line_width(cr, 1.0 * u);
  cairo_stroke(cr);
  drawText(cr, L.legend_font, kInk, "0", L.bar_left, L.bar_label_base, 0.5);
  drawText(cr, L.legend_font, kInk, formatLength(L.bar_m), L.bar_left + L.bar_px, L.bar_label_base, 0.5);
  // the middle label when it has room
  const std::string mid = formatLength(L.bar_m / 2);
  const double mid_w = textWidth(cr, L.legend_font, mid), end_w = textWidth(cr, L.legend_font, formatLength(L.bar_m));
  if (L.bar_segments % 2 == 0 && L.bar_px / 2 - mid_w / 2 - end_w / 2 > 12 * u)
    drawText(cr, L.legend_font, kInk, formatNumber(L.bar_m / 2, decimalsFor(L.bar_m / 2)), L.bar_left + L.bar_px / 2,
             L.bar_label_base, 0.5);
}

void drawAxes(cairo_t* cr, const Layout& L) {
  const double u = L.u;
  const double left = L.map_left, top = L.map_top, bottom = L.map_top + L.mh;
  // frame just outside the raster, so no map pixel is covered
  cairo_set_line_width(cr, 1.0);
  cairo_rectangle(cr, left - 0.5, top - 0.5, L.mw + 1.0, L.mh + 1.0);
  setColour(cr, kFrame);
  cairo_stroke(cr);
  cairo_set_line_width(cr, std::max(1.0, 0.9 * u));
  for (std::size_t k = 0; k < L.xt.values.size(); ++k) {
    const double px = left + (L.xt.values[k] - L.x0) * L.s;
    cairo_move_to(cr, px, bottom + 1);
    cairo_line_to(cr, px, bottom + 1 + L.tick_len);
    setColour(cr, kFrame);
    cairo_stroke(cr);
    drawText(cr, L.tick_font, kMutedInk, L.xt.labels[k], px, L.xlabel_base, 0.5);
  }
  for (std::size_t k = 0; k < L.yt.values.size(); ++k) {
    const double py = top + (L.y1 - L.yt.values[k]) * L.s;
    cairo_move_to(cr, left - 1, py);
    cairo_line_to(cr, left - 1 - L.tick_len, py);
    setColour(cr, kFrame);
    cairo_stroke(cr);
    drawText(cr, L.tick_font, kMutedInk, L.yt.labels[k], L.ylabel_right, py + 0.36 * L.tick_font.size, 1.0);
  }
}

/// Everything but the raster; `raster`, when given, is painted into the map area first.
void drawPicture(cairo_t* cr, const Layout& L, cairo_surface_t* raster) {
  setupText(cr);
  if (raster) {
    cairo_save(cr);
    cairo_rectangle(cr, L.map_left, L.map_top, L.mw, L.mh);
    cairo_clip(cr);
    cairo_set_source_surface(cr, raster, L.map_left, L.map_top);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
    cairo_restore(cr);
  }
  if (!L.title.empty()) drawText(cr, L.title_font, kInk, L.title, L.margin, L.title_base);
  drawText(cr, L.caption_font, kMutedInk, L.caption, L.margin, L.caption_base);
  drawAxes(cr, L);
  drawNorthArrow(cr, L);
  drawLegend(cr, L);
  drawScaleBar(cr, L);
}

void fillPage(cairo_t* cr, const Layout& L, bool skip_map_area) {
  setColour(cr, kPage);
  if (skip_map_area) {
    cairo_set_fill_rule(cr, CAIRO_FILL_RULE_EVEN_ODD);
    cairo_rectangle(cr, 0, 0, L.width, L.height);
    cairo_rectangle(cr, L.map_left, L.map_top, L.mw, L.mh);
    cairo_fill(cr);
    cairo_set_fill_rule(cr, CAIRO_FILL_RULE_WINDING);
  } else {
    cairo_paint(cr);
  }
}

cairo_status_t writeToStream(void* closure, const unsigned char* data, unsigned int length) {
  auto* os = static_cast<std::ostream*>(closure);
  os->write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(length));
  return os->good() ? CAIRO_STATUS_SUCCESS : CAIRO_STATUS_WRITE_ERROR;
}

Status validate(const OccupancyMap& map, const TopViewOptions& o, const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext.empty()) return adit::invalidArgument(path + ": no file extension; use .png or .svg");
  if (ext != ".png" && ext != ".svg")
    return adit::invalidArgument(path + ": unknown picture format '" + ext + "'; use .png or .svg");
  auto bad = [](const char* field, double v, const char* rule) {
    std::ostringstream os;
    os << "top view: " << field << " = " << v << " " << rule;
    return adit::invalidArgument(os.str());
  };
  if (!std::isfinite(o.pixels_per_m) || o.pixels_per_m < 0)
    return bad("pixels_per_m", o.pixels_per_m, "must be finite and >= 0 (0 = automatic)");
  if (o.pixels_per_m == 0 && o.max_pixels < 16) return bad("max_pixels", o.max_pixels, "must be at least 16");
  if (o.slice_z_m && !std::isfinite(*o.slice_z_m)) return bad("slice_z_m", *o.slice_z_m, "must be finite");
  if (!std::isfinite(o.slice_band_m) || o.slice_band_m < 0)
    return bad("slice_band_m", o.slice_band_m, "must be finite and >= 0");
  if (!std::isfinite(o.min_roadway_width_m) || o.min_roadway_width_m <= 0)
    return bad("min_roadway_width_m", o.min_roadway_width_m, "must be finite and > 0");
  if (!std::isfinite(o.max_megapixels) || o.max_megapixels <= 0)
    return bad("max_megapixels", o.max_megapixels, "must be finite and > 0");
  const Aabb b = map.bounds();
  if (b.empty() || !map::allFinite(b.min) || !map::allFinite(b.max))
    return adit::failedPrecondition("top view: the map has no known voxel to draw");
  // Fail before the work when the file cannot be placed (writeFileAtomically checks again).
  const std::filesystem::path target(path);
  const std::filesystem::path dir = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    return adit::notFound(path + ": directory '" + dir.string() + "' does not exist");
  return {};
}

}  // namespace

Status renderTopView(const OccupancyMap& map, const TopViewOptions& options, const std::string& path,
                     TopViewInfo* info) {
  ADIT_RETURN_IF_ERROR(validate(map, options, path));
  const bool svg = lowerExtension(path) == ".svg";

  // Measure on a scratch surface, with a first layout to size the raster.
  SurfacePtr scratch(cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1));
  ContextPtr mcr(cairo_create(scratch.get()));
  if (cairo_status(mcr.get()) != CAIRO_STATUS_SUCCESS)
    return cairoFailure(path, "create a drawing context", cairo_status(mcr.get()));
  setupText(mcr.get());
  Layout L;
  bool raised = false;
  ADIT_RETURN_IF_ERROR(computeLayout(map, options, mcr.get(), L, raised, nullptr));

  // The raster: straight into the picture for PNG, a separate image to embed for SVG.
  SurfacePtr picture, raster;
  RasterStats stats;
  if (!svg) {
    picture.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24, L.width, L.height));
    if (cairo_surface_status(picture.get()) != CAIRO_STATUS_SUCCESS)
      return cairoFailure(path, "allocate the picture", cairo_surface_status(picture.get()));
    cairo_surface_flush(picture.get());
    auto* data = cairo_image_surface_get_data(picture.get());
    const std::size_t stride = cairo_image_surface_get_stride(picture.get()) / 4;
    std::uint32_t* base = reinterpret_cast<std::uint32_t*>(data) + L.map_top * stride + L.map_left;
    stats = rasterise(map, options, L, base, stride);
    cairo_surface_mark_dirty(picture.get());
  } else {
    raster.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24, L.mw, L.mh));
    if (cairo_surface_status(raster.get()) != CAIRO_STATUS_SUCCESS)
      return cairoFailure(path, "allocate the raster", cairo_surface_status(raster.get()));
    cairo_surface_flush(raster.get());
    const std::size_t stride = cairo_image_surface_get_stride(raster.get()) / 4;
    stats = rasterise(map, options, L, reinterpret_cast<std::uint32_t*>(cairo_image_surface_get_data(raster.get())),
                      stride);
    cairo_surface_mark_dirty(raster.get());
  }
  // Final layout with the real floor range. Its geometry nearly always equals the first one's (the
  // legend was sized for the map's height range); when it does not, e.g. a flat map whose ramp
  // becomes one swatch, the map area moves into a picture of the final size.
  Layout final_layout;
  ADIT_RETURN_IF_ERROR(computeLayout(map, options, mcr.get(), final_layout, raised, &stats));
  if (final_layout.width != L.width || final_layout.height != L.height || final_layout.map_left != L.map_left ||
      final_layout.map_top != L.map_top) {
    if (!svg) {
      SurfacePtr resized(cairo_image_surface_create(CAIRO_FORMAT_RGB24, final_layout.width, final_layout.height));
      if (cairo_surface_status(resized.get()) != CAIRO_STATUS_SUCCESS)
        return cairoFailure(path, "allocate the picture", cairo_surface_status(resized.get()));
      ContextPtr cr(cairo_create(resized.get()));
      cairo_set_operator(cr.get(), CAIRO_OPERATOR_SOURCE);
      cairo_set_source_surface(cr.get(), picture.get(), final_layout.map_left - L.map_left,
                               final_layout.map_top - L.map_top);
      cairo_rectangle(cr.get(), final_layout.map_left, final_layout.map_top, L.mw, L.mh);
      cairo_fill(cr.get());
      if (cairo_status(cr.get()) != CAIRO_STATUS_SUCCESS)
        return cairoFailure(path, "copy the raster", cairo_status(cr.get()));
      cr.reset();
      picture = std::move(resized);
    }
  }
  L = final_layout;

  cairo_status_t cst = CAIRO_STATUS_SUCCESS;
  const char* stage = "draw";
  Status written;
  if (!svg) {
    {
      ContextPtr cr(cairo_create(picture.get()));
      fillPage(cr.get(), L, /*skip_map_area=*/true);
      drawPicture(cr.get(), L, nullptr);
      cst = cairo_status(cr.get());
    }
    if (cst != CAIRO_STATUS_SUCCESS) return cairoFailure(path, "draw the picture", cst);
    cairo_surface_flush(picture.get());
    stage = "encode the PNG";
    written = map::writeFileAtomically(path, [&](std::ostream& os) {
      cst = cairo_surface_write_to_png_stream(picture.get(), writeToStream, &os);
      return cst == CAIRO_STATUS_SUCCESS;
    });
  } else {
    stage = "write the SVG";
    written = map::writeFileAtomically(path, [&](std::ostream& os) {
      SurfacePtr surface(cairo_svg_surface_create_for_stream(writeToStream, &os, L.width, L.height));
      cst = cairo_surface_status(surface.get());
      if (cst != CAIRO_STATUS_SUCCESS) return false;
      cairo_svg_surface_set_document_unit(surface.get(), CAIRO_SVG_UNIT_PX);
      {
        ContextPtr cr(cairo_create(surface.get()));
        fillPage(cr.get(), L, /*skip_map_area=*/false);
        drawPicture(cr.get(), L, raster.get());
        cst = cairo_status(cr.get());
      }
      if (cst != CAIRO_STATUS_SUCCESS) return false;
      cairo_surface_finish(surface.get());
      cst = cairo_surface_status(surface.get());
      return cst == CAIRO_STATUS_SUCCESS;
    });
  }
  // A stream failure is the writer's to explain; any other Cairo failure is ours.
  if (cst != CAIRO_STATUS_SUCCESS && cst != CAIRO_STATUS_WRITE_ERROR) return cairoFailure(path, stage, cst);
  ADIT_RETURN_IF_ERROR(written);

  if (info) {
    TopViewInfo out;
    out.width_px = L.width;
    out.height_px = L.height;
    out.pixels_per_m = L.s;
    out.scale_raised = raised;
    out.map_left_px = L.map_left;
    out.map_top_px = L.map_top;
    out.map_width_px = L.mw;
    out.map_height_px = L.mh;
    out.x_min_m = L.x0;
    out.y_max_m = L.y1;
    out.floor_min_m = L.fmin;
    out.floor_max_m = L.fmax;
    out.scale_bar_m = L.bar_m;
    out.free_pixels = stats.free_pixels;
    *info = out;
  }
  return {};
}

}  // namespace adit::tools

#if defined(__SANITIZE_ADDRESS__)
// Fontconfig (under Cairo's text) keeps its process-lifetime configuration and pattern caches
// behind encoded pointers that LeakSanitizer cannot follow, so every binary that draws text would
// report them as leaks at exit. Weak, so that a binary with its own suppressions keeps them.
extern "C" __attribute__((weak)) const char* __lsan_default_suppressions() { return "leak:libfontconfig.so\n"; }
#endif
