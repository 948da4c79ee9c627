// SPDX-License-Identifier: BSD-3-Clause
// The one renderer: the top view is one pass over the octree leaves into a 32-bit raster (per
// pixel the lowest floor key, or the strongest slice state), coloured in place; overlays (lines,
// markers, discs) are drawn over it, then the annotations (axes, legend, scale bar, north arrow,
// side profile) with Cairo. renderTopView() is a Figure without overlays.
#include "common/figure.hpp"

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
#include <unordered_map>
#include <vector>

#include "adit/map/map_io.hpp"
#include "common/label_layout.hpp"
#include "common/markup.hpp"

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
// Plasma (matplotlib, CC0) for overlay values such as time: unlike viridis it never matches the
// floor colours under it. Its darkest tenth is skipped for the same reason as viridis'.
constexpr std::array<std::uint32_t, 11> kPlasma = {0x0D0887, 0x41049D, 0x6A00A8, 0x8F0DA4,
                                                   0xB12A90, 0xCC4778, 0xE16462, 0xF2844B,
                                                   0xFCA636, 0xFCCE25, 0xF0F921};
constexpr std::uint32_t kOpenSpace = 0xF2EFE8;  ///< the map area of a figure without a map

std::uint32_t sampleRamp(const std::array<std::uint32_t, 11>& stops, double t) {
  const double v = kRampStart + (1.0 - kRampStart) * std::clamp(t, 0.0, 1.0);
  const double f = v * 10.0;
  const int i = std::min(static_cast<int>(f), 9);
  const double a = f - i;
  std::uint32_t out = 0;
  for (int shift = 16; shift >= 0; shift -= 8) {
    const double c0 = (stops[i] >> shift) & 0xFF, c1 = (stops[i + 1] >> shift) & 0xFF;
    out |= static_cast<std::uint32_t>(std::lround(c0 + a * (c1 - c0))) << shift;
  }
  return out;
}
std::uint32_t rampColour(double t) { return sampleRamp(kViridis, t); }
std::uint32_t valueColour(double t) { return sampleRamp(kPlasma, t); }

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

/// Text kept aside while drawing an SVG, to be written as <text> elements (Cairo's SVG surface
/// writes glyph outlines, which no one can search, select, translate or restyle).
struct SvgText {
  double x = 0, y = 0;  ///< device pixels; the baseline's start, middle or end (by `align`)
  Font font;
  std::uint32_t colour = 0;
  double align = 0.0;
  bool halo = false;
  std::string text;
};
cairo_user_data_key_t kSvgTextKey;

/// The SVG's text list when `cr` draws an SVG, else null.
std::vector<SvgText>* svgTextSink(cairo_t* cr) {
  return static_cast<std::vector<SvgText>*>(cairo_get_user_data(cr, &kSvgTextKey));
}

void keepSvgText(std::vector<SvgText>* sink, cairo_t* cr, const Font& f, std::uint32_t colour, const std::string& s,
                 double x, double y, double align, bool halo) {
  cairo_user_to_device(cr, &x, &y);
  sink->push_back({x, y, f, colour, align, halo, s});
}

/// Draws `s` with its baseline at y; align 0 = left, 0.5 = centre, 1 = right of x.
void drawText(cairo_t* cr, const Font& f, std::uint32_t colour, const std::string& s, double x, double y,
              double align = 0.0) {
  if (std::vector<SvgText>* sink = svgTextSink(cr)) return keepSvgText(sink, cr, f, colour, s, x, y, align, false);
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

enum class GlyphKind { kLine, kMarker, kDisc };

/// One row of the overlays' legend.
struct LegendItem {
  GlyphKind kind = GlyphKind::kLine;
  std::uint32_t colour = 0, stroke = 0;
  bool dashed = false;
  MarkerShape shape = MarkerShape::kCircle;
  double fill_alpha = 1.0;
  std::string text;
};

/// The colour bar of the overlays' per-vertex values (e.g. time along a trajectory).
struct ValueRamp {
  std::string label;
  double vmin = 0, vmax = 0;
};

/// What the layout needs to know of the figure besides the options.
struct Content {
  const OccupancyMap* map = nullptr;
  Aabb bounds;  ///< world extent drawn (x-y used; z for the caption when there is a map)
  std::vector<LegendItem> items;
  std::optional<ValueRamp> value_ramp;
  const SideProfile* profile = nullptr;
};

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

  // overlays' legend (below the map legend) and the value colour bar
  bool has_map = true;
  std::vector<LegendItem> items;
  std::optional<ValueRamp> value_ramp;
  double value_ramp_height = 0;

  // side profile panel (below the scale bar)
  const SideProfile* profile = nullptr;
  double prof_title_base = 0, prof_left = 0, prof_top = 0, prof_w = 0, prof_h = 0;
  double prof_s0 = 0, prof_s1 = 1, prof_z0 = 0, prof_z1 = 1;
  Ticks pst, pzt;
  double prof_xlabel_base = 0;
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
  if (!L.has_map) {
    w = std::max(w, swatch_row + textWidth(cr, L.legend_font, "Open space"));
    h += L.row_h;
  } else if (!L.slice) {
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
  if (!L.items.empty()) {
    h += 12 * u;
    for (const LegendItem& it : L.items) {
      w = std::max(w, swatch_row + textWidth(cr, L.legend_font, it.text));
      h += L.row_h;
    }
  }
  if (L.value_ramp) {
    h += 12 * u + lineMetrics(cr, L.legend_title_font).height() + 4 * u + L.value_ramp_height + 12 * u;
    w = std::max(w, textWidth(cr, L.legend_title_font, L.value_ramp->label));
    double lw = 0;
    for (double v : {L.value_ramp->vmin, L.value_ramp->vmax})
      lw = std::max(lw, textWidth(cr, L.legend_font, formatNumber(v, 1)));
    w = std::max(w, L.ramp_width + 10 * u + lw);
  }
  return {w, h};
}

Status computeLayout(const Content& C, const TopViewOptions& o, cairo_t* cr, Layout& L, bool& raised,
                     const RasterStats* stats) {
  const Aabb b = C.bounds;
  L.has_map = C.map != nullptr;
  L.items = C.items;
  L.value_ramp = C.value_ramp;
  L.profile = C.profile;
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
  L.slice = L.has_map && o.slice_z_m.has_value();
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
  L.value_ramp_height = 120 * u;

  // Title and caption.
  L.title = o.title;
  const double res = L.has_map ? C.map->resolution() : 0.1;
  {
    const int d = decimalsFor(res);
    const int de = std::max(1, std::min(d, 2));
    std::ostringstream os;
    if (L.has_map)
      os << "Resolution " << formatNumber(res, d) << " m  \u00b7  extent " << formatNumber(wx, de) << " \u00d7 "
         << formatNumber(wy, de) << " m, z " << formatNumber(b.min.z(), de) << " to "
         << formatNumber(b.max.z(), de) << " m  \u00b7  ";
    else
      os << "Open space, extent " << formatNumber(wx, de) << " \u00d7 " << formatNumber(wy, de) << " m  \u00b7  ";
    os 
       << (s >= 1 ? formatNumber(s, s >= 10 ? 1 : 2) + " px/m" : "1 px = " + formatNumber(1 / s, 2) + " m")
       << "  \u00b7  coordinates in m, x east, y north";
    L.caption = os.str();
  }

  // Legend contents.
  if (!L.has_map) {
    L.legend_title = "World";
  } else if (L.slice) {
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
  double bar_bottom = L.bar_label_base + lm.descent;
  double prof_right = 0;
  if (L.profile) {
    // The side profile: its own axes under the scale bar, as wide as the map area (at least
    // 420 px, so that a tall narrow map still gets a readable profile).
    const SideProfile& P = *L.profile;
    const LineMetrics ptm = lineMetrics(cr, L.legend_title_font);
    L.prof_title_base = bar_bottom + 26 * u + ptm.ascent;
    L.prof_top = L.prof_title_base + ptm.descent + 10 * u;
    L.prof_h = std::max(60.0, P.height_px) * u;
    L.prof_w = std::max<double>(L.mw, 420 * u);
    double s0 = std::numeric_limits<double>::infinity(), s1 = -s0, z0 = s0, z1 = -s0;
    for (const ProfileSeries& ser : P.series)
      for (std::size_t k = 0; k < ser.s_m.size(); ++k) {
        s0 = std::min(s0, ser.s_m[k]);
        s1 = std::max(s1, ser.s_m[k]);
        z0 = std::min(z0, ser.z_m[k]);
        z1 = std::max(z1, ser.z_m[k]);
      }
    for (const ProfileLabel& lab : P.labels) {
      z0 = std::min(z0, lab.z_m);
      z1 = std::max(z1, lab.z_m);
    }
    if (!(s1 >= s0)) { s0 = 0; s1 = 1; }
    if (!(z1 >= z0)) { z0 = 0; z1 = 1; }
    if (s1 - s0 < 1e-9) s1 = s0 + 1;
    const double zpad = std::max(0.5, 0.12 * (z1 - z0));
    L.prof_s0 = s0;
    L.prof_s1 = s1;
    L.prof_z0 = z0 - zpad;
    L.prof_z1 = z1 + zpad;
    double pstep = niceAtLeast(std::max((s1 - s0) * 70 * u / L.prof_w, 1e-3));
    for (;;) {
      L.pst = makeTicks(cr, L.tick_font, s0, s1, pstep);
      if (pstep / (s1 - s0) * L.prof_w >= L.pst.max_label_width + 18 * u) break;
      pstep = nextNice(pstep);
    }
    const double zstep =
        niceAtLeast(std::max((L.prof_z1 - L.prof_z0) * 2.5 * tick_m.height() / L.prof_h, 1e-3));
    L.pzt = makeTicks(cr, L.tick_font, L.prof_z0, L.prof_z1, zstep);
    L.prof_left = std::max<double>(L.map_left, M + L.pzt.max_label_width + L.tick_len + 5 * u);
    L.prof_xlabel_base = L.prof_top + L.prof_h + L.tick_len + 4 * u + tick_m.ascent;
    bar_bottom = L.prof_xlabel_base + tick_m.descent;
    prof_right = L.prof_left + L.prof_w + L.pst.max_label_width / 2;
    double legend_x = L.prof_left;
    for (const ProfileSeries& ser : P.series)
      if (!ser.legend.empty()) legend_x += L.swatch_w + 14 * u + textWidth(cr, L.legend_font, ser.legend);
    prof_right = std::max(prof_right, legend_x + textWidth(cr, L.legend_title_font, P.title) + 20 * u);
  }

  double right = std::max({L.map_left + L.mw + L.xt.max_label_width / 2, L.panel_left + panel_w, prof_right,
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
  // The band in voxel units. A leaf spans [kb, kt) voxels; its float centre is not exact (0.55 may
  // be 0.5500001), so its ends are rounded to the voxel grid and the band is compared with a
  // tolerance: a slice exactly on a voxel boundary (z = 0.5 on a 0.1 m map) then meets the voxel
  // above it, and only that one, instead of neither.
  const double band_lo = zlo / res, band_hi = zhi / res;
  const double x1 = L.x0 + L.mw / s, y0 = L.y1 - L.mh / s;  // the map area's other edges
  map.forEachLeaf([&](const Vec3& c, double size, VoxelState state) {
    const double h = 0.5 * size;
    if (c.x() + h <= L.x0 || c.x() - h >= x1 || c.y() + h <= y0 || c.y() - h >= L.y1) return;  // off the view
    if (slice) {
      const double kb = std::round((c.z() - h) / res), kt = std::round((c.z() + h) / res);
      if (kb > band_hi + 1e-6 || kt <= band_lo + 1e-6) return;  // [kb, kt) does not meet the band
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

void drawOverlayLegend(cairo_t* cr, const Layout& L, double y);

/// A vertical colour bar (top = 1), as one gradient so that SVG keeps it as one element.
void drawColourBar(cairo_t* cr, std::uint32_t (*colour)(double), double x, double top, double w, double h,
                   double u) {
  cairo_pattern_t* grad = cairo_pattern_create_linear(0, top + h, 0, top);
  constexpr int kStops = 40;
  for (int k = 0; k <= kStops; ++k) {
    const std::uint32_t c = colour(double(k) / kStops);
    cairo_pattern_add_color_stop_rgb(grad, double(k) / kStops, ((c >> 16) & 0xFF) / 255.0,
                                     ((c >> 8) & 0xFF) / 255.0, (c & 0xFF) / 255.0);
  }
  cairo_rectangle(cr, x, top, w, h);
  cairo_set_source(cr, grad);
  cairo_fill(cr);
  cairo_pattern_destroy(grad);
  cairo_rectangle(cr, x, top, w, h);
  setColour(cr, kFrame);
  cairo_set_line_width(cr, 1.0 * u);
  cairo_stroke(cr);
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
  if (!L.has_map) {
    drawSwatch(cr, L, x, y, kOpenSpace, "Open space");
    drawOverlayLegend(cr, L, y + L.row_h);
    return;
  }
  if (L.slice) {
    drawSwatch(cr, L, x, y, kTopViewSliceFree, "Free");
    drawSwatch(cr, L, x, y + L.row_h, kTopViewSliceOccupied, "Occupied (rock)");
    drawSwatch(cr, L, x, y + 2 * L.row_h, kTopViewBackground, "Unknown");
    drawOverlayLegend(cr, L, y + 3 * L.row_h);
    return;
  }
  if (L.fmin && *L.fmax > *L.fmin) {
    const double top = y + 4 * u, h = L.ramp_height, w = L.ramp_width;
    const double fmin = *L.fmin, fmax = *L.fmax, span = fmax - fmin;
    drawColourBar(cr, rampColour, x, top, w, h, u);
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
  drawOverlayLegend(cr, L, y + L.row_h);
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

// ---- overlays --------------------------------------------------------------------------------------

/// What the label layouts of one picture did (reported in TopViewInfo).
struct LabelCounts {
  std::size_t labels = 0, merged = 0, leaders = 0, overlaps = 0;
};

struct Overlays {
  const std::vector<FigureLine>& lines;
  const std::vector<FigureMarker>& markers;
  const std::vector<FigureDisc>& discs;
};

void setDash(cairo_t* cr, bool dashed, double u) {
  if (dashed) {
    const double d[] = {7 * u, 5 * u};
    cairo_set_dash(cr, d, 2, 0);
  } else {
    cairo_set_dash(cr, nullptr, 0, 0);
  }
}

/// A marker's path centred at (x, y) with diameter d (filled by the caller; kCross is stroked).
void markerPath(cairo_t* cr, MarkerShape shape, double x, double y, double d) {
  const double r = d / 2;
  switch (shape) {
    case MarkerShape::kCircle: cairo_arc(cr, x, y, r, 0, 2 * M_PI); break;
    case MarkerShape::kSquare: cairo_rectangle(cr, x - 0.85 * r, y - 0.85 * r, 1.7 * r, 1.7 * r); break;
    case MarkerShape::kTriangle:
      cairo_move_to(cr, x, y - 1.1 * r);
      cairo_line_to(cr, x + r, y + 0.75 * r);
      cairo_line_to(cr, x - r, y + 0.75 * r);
      cairo_close_path(cr);
      break;
    case MarkerShape::kDiamond:
      cairo_move_to(cr, x, y - 1.15 * r);
      cairo_line_to(cr, x + r, y);
      cairo_line_to(cr, x, y + 1.15 * r);
      cairo_line_to(cr, x - r, y);
      cairo_close_path(cr);
      break;
    case MarkerShape::kCross:
      cairo_move_to(cr, x - r, y - r);
      cairo_line_to(cr, x + r, y + r);
      cairo_move_to(cr, x + r, y - r);
      cairo_line_to(cr, x - r, y + r);
      break;
  }
}

void drawMarkerGlyph(cairo_t* cr, MarkerShape shape, std::uint32_t colour, double x, double y, double d, double u) {
  markerPath(cr, shape, x, y, d);
  if (shape == MarkerShape::kCross) {
    cairo_set_line_width(cr, std::max(2.0, 0.22 * d));
    setColour(cr, kInk);
    cairo_stroke_preserve(cr);
    cairo_set_line_width(cr, std::max(1.2, 0.12 * d));
    setColour(cr, colour);
    cairo_stroke(cr);
    return;
  }
  setColour(cr, colour);
  cairo_fill_preserve(cr);
  setColour(cr, kInk);
  cairo_set_line_width(cr, 1.3 * u);
  cairo_stroke(cr);
}

/// Text with a light halo, legible over any colour of the map.
void drawHaloText(cairo_t* cr, const Font& f, const std::string& s, double x, double y) {
  if (std::vector<SvgText>* sink = svgTextSink(cr)) return keepSvgText(sink, cr, f, kInk, s, x, y, 0.0, true);
  useFont(cr, f);
  cairo_move_to(cr, x, y);
  cairo_text_path(cr, s.c_str());
  setColour(cr, kPage, 0.85);
  cairo_set_line_width(cr, 0.3 * f.size);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_stroke_preserve(cr);
  setColour(cr, kInk);
  cairo_fill(cr);
}

/// Lays out the labels of `anchors` inside `area` (label_layout.hpp) and draws them, leader lines
/// first so that no line crosses a label's text.
LabelLayoutResult drawLabels(cairo_t* cr, const Font& f, double u, const std::vector<LabelAnchor>& anchors,
                             const LabelBox& area) {
  const LineMetrics m = lineMetrics(cr, f);
  LabelLayoutParams params;
  params.area = area;
  params.gap_px = 3 * u;
  params.padding_px = 0.15 * f.size;  // the halo's reach
  LabelLayoutResult r = layoutLabels(anchors, params, [&](const std::string& s) {
    return std::pair<double, double>(textWidth(cr, f, s), m.height());
  });
  for (const PlacedLabel& p : r.labels) {
    if (!p.leader) continue;
    cairo_move_to(cr, p.lx0, p.ly0);
    cairo_line_to(cr, p.lx1, p.ly1);
    setColour(cr, kPage, 0.8);
    cairo_set_line_width(cr, 2.6 * u);
    cairo_stroke_preserve(cr);
    setColour(cr, kInk);
    cairo_set_line_width(cr, 1.0 * u);
    cairo_stroke(cr);
  }
  for (const PlacedLabel& p : r.labels) drawHaloText(cr, f, p.text, p.box.x0, p.box.y0 + m.ascent);
  return r;
}

void addLabelCounts(const LabelLayoutResult& r, LabelCounts& c) {
  c.labels += r.labels.size();
  c.merged += r.merged_anchors;
  c.leaders += r.leaders;
  c.overlaps += r.overlaps;
}

/// The value range of every line that has values (the one colour bar they share).
std::optional<ValueRamp> valueRange(const std::vector<FigureLine>& lines) {
  std::optional<ValueRamp> r;
  for (const FigureLine& l : lines) {
    if (l.values.empty()) continue;
    if (!r) r = ValueRamp{l.values_label.empty() ? std::string("value") : l.values_label,
                          std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (double v : l.values) {
      r->vmin = std::min(r->vmin, v);
      r->vmax = std::max(r->vmax, v);
    }
  }
  return r;
}

void drawOverlays(cairo_t* cr, const Layout& L, const Overlays& ov, LabelCounts& counts) {
  const double u = L.u;
  auto px = [&](const Vec3& p) { return L.map_left + (p.x() - L.x0) * L.s; };
  auto py = [&](const Vec3& p) { return L.map_top + (L.y1 - p.y()) * L.s; };
  cairo_save(cr);
  cairo_rectangle(cr, L.map_left, L.map_top, L.mw, L.mh);
  cairo_clip(cr);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const FigureDisc& d : ov.discs) {
    cairo_new_path(cr);
    cairo_arc(cr, px(d.center), py(d.center), std::max(2.0, d.radius_m * L.s), 0, 2 * M_PI);
    setColour(cr, d.fill, d.fill_alpha);
    cairo_fill_preserve(cr);
    setColour(cr, d.stroke);
    cairo_set_line_width(cr, 1.2 * u);
    cairo_stroke(cr);
  }
  const std::optional<ValueRamp> ramp = valueRange(ov.lines);
  for (const FigureLine& l : ov.lines) {
    if (l.points.size() < 2) continue;
    const double w = l.width_px * u;
    setDash(cr, l.dashed, u);
    if (l.values.empty()) {
      // a dark casing under the line keeps it visible on light and dark ground alike
      for (int pass = 0; pass < 2; ++pass) {
        cairo_move_to(cr, px(l.points[0]), py(l.points[0]));
        for (std::size_t k = 1; k < l.points.size(); ++k) cairo_line_to(cr, px(l.points[k]), py(l.points[k]));
        setColour(cr, pass == 0 ? kInk : l.colour, pass == 0 ? 0.55 : 1.0);
        cairo_set_line_width(cr, pass == 0 ? w + 2 * u : w);
        cairo_stroke(cr);
      }
    } else {
      const double span = ramp && ramp->vmax > ramp->vmin ? ramp->vmax - ramp->vmin : 0.0;
      for (std::size_t k = 1; k < l.points.size(); ++k) {
        const double v = 0.5 * (l.values[k - 1] + l.values[k]);
        cairo_move_to(cr, px(l.points[k - 1]), py(l.points[k - 1]));
        cairo_line_to(cr, px(l.points[k]), py(l.points[k]));
        setColour(cr, valueColour(span > 0 ? (v - ramp->vmin) / span : 0.5));
        cairo_set_line_width(cr, w);
        cairo_stroke(cr);
      }
    }
  }
  setDash(cr, false, u);
  for (const FigureMarker& m : ov.markers)
    drawMarkerGlyph(cr, m.shape, m.colour, px(m.position), py(m.position), m.size_px * u, u);
  // Every marker is an anchor (an unlabelled one only keeps labels off it); markers of one shape,
  // colour and priority form a group whose crowded members share a label.
  std::vector<LabelAnchor> anchors;
  std::vector<int> group_size;
  for (std::size_t i = 0; i < ov.markers.size(); ++i) {
    const FigureMarker& m = ov.markers[i];
    LabelAnchor a;
    a.x = px(m.position);
    a.y = py(m.position);
    // the shapes other than the circle reach a little beyond half their size (markerPath)
    a.radius = (m.shape == MarkerShape::kCircle ? 0.5 : 0.6) * m.size_px * u;
    a.text = m.label;
    a.priority = m.label_priority;
    a.group = static_cast<int>(i);
    for (std::size_t j = 0; j < i; ++j) {
      const FigureMarker& o = ov.markers[j];
      if (o.shape == m.shape && o.colour == m.colour && o.label_priority == m.label_priority) {
        a.group = anchors[j].group;
        break;
      }
    }
    if (m.label_priority <= 0) a.group = -1;
    group_size.resize(std::max<std::size_t>(group_size.size(), a.group + 1), 0);
    if (a.group >= 0 && !m.label.empty()) a.sequence = group_size[a.group]++;
    anchors.push_back(std::move(a));
  }
  // Obstacle discs are translucent: their labels keep off markers but others may cross them.
  for (const FigureDisc& d : ov.discs) {
    if (d.label.empty()) continue;
    LabelAnchor a;
    a.x = px(d.center);
    a.y = py(d.center);
    a.radius = std::max(2.0, d.radius_m * L.s);
    a.text = d.label;
    a.priority = 2;
    a.obstacle = false;
    anchors.push_back(std::move(a));
  }
  const double inset = 2 * u;
  addLabelCounts(drawLabels(cr, Font{12.5 * u, true}, u, anchors,
                            {L.map_left + inset, L.map_top + inset, L.map_left + L.mw - inset, L.map_top + L.mh - inset}),
                 counts);
  cairo_restore(cr);
}

/// The overlays' legend rows and the value colour bar, from `y` down in the legend panel.
void drawOverlayLegend(cairo_t* cr, const Layout& L, double y) {
  const double u = L.u, x = L.panel_left;
  if (!L.items.empty()) {
    y += 12 * u;
    for (const LegendItem& it : L.items) {
      const double cy = y + L.swatch_h / 2;
      switch (it.kind) {
        case GlyphKind::kLine:
          setDash(cr, it.dashed, u * 0.6);
          cairo_move_to(cr, x, cy);
          cairo_line_to(cr, x + L.swatch_w, cy);
          setColour(cr, it.colour);
          cairo_set_line_width(cr, 3 * u);
          cairo_stroke(cr);
          setDash(cr, false, u);
          break;
        case GlyphKind::kMarker:
          drawMarkerGlyph(cr, it.shape, it.colour, x + L.swatch_w / 2, cy, 10 * u, u);
          break;
        case GlyphKind::kDisc:
          cairo_arc(cr, x + L.swatch_w / 2, cy, 6 * u, 0, 2 * M_PI);
          setColour(cr, it.colour, it.fill_alpha);
          cairo_fill_preserve(cr);
          setColour(cr, it.stroke);
          cairo_set_line_width(cr, 1.2 * u);
          cairo_stroke(cr);
          break;
      }
      drawText(cr, L.legend_font, kInk, it.text, x + L.swatch_w + 8 * u, cy + 0.36 * L.legend_font.size);
      y += L.row_h;
    }
  }
  if (L.value_ramp) {
    const ValueRamp& r = *L.value_ramp;
    y += 12 * u;
    const LineMetrics tm = lineMetrics(cr, L.legend_title_font);
    drawText(cr, L.legend_title_font, kInk, r.label, x, y + tm.ascent);
    const double top = y + tm.height() + 4 * u, h = L.value_ramp_height, w = L.ramp_width;
    drawColourBar(cr, valueColour, x, top, w, h, u);
    drawText(cr, L.legend_font, kInk, formatNumber(r.vmax, 1), x + w + 9 * u, top + 0.36 * L.legend_font.size);
    drawText(cr, L.legend_font, kInk, formatNumber(r.vmin, 1), x + w + 9 * u, top + h + 0.36 * L.legend_font.size);
  }
}

void drawProfile(cairo_t* cr, const Layout& L, LabelCounts& counts) {
  if (!L.profile) return;
  const SideProfile& P = *L.profile;
  const double u = L.u, left = L.prof_left, top = L.prof_top, w = L.prof_w, h = L.prof_h;
  auto X = [&](double sv) { return left + (sv - L.prof_s0) / (L.prof_s1 - L.prof_s0) * w; };
  auto Y = [&](double zv) { return top + (L.prof_z1 - zv) / (L.prof_z1 - L.prof_z0) * h; };
  // title, then the series' legend on the same line
  drawText(cr, L.legend_title_font, kInk, P.title, left, L.prof_title_base);
  double lx = left + textWidth(cr, L.legend_title_font, P.title) + 20 * u;
  for (const ProfileSeries& ser : P.series) {
    if (ser.legend.empty()) continue;
    const double cy = L.prof_title_base - 0.36 * L.legend_font.size;
    setDash(cr, ser.dashed, 0.6 * u);
    cairo_move_to(cr, lx, cy);
    cairo_line_to(cr, lx + L.swatch_w, cy);
    setColour(cr, ser.colour);
    cairo_set_line_width(cr, 3 * u);
    cairo_stroke(cr);
    setDash(cr, false, u);
    drawText(cr, L.legend_font, kInk, ser.legend, lx + L.swatch_w + 6 * u, L.prof_title_base);
    lx += L.swatch_w + 14 * u + textWidth(cr, L.legend_font, ser.legend);
  }
  cairo_rectangle(cr, left, top, w, h);
  setColour(cr, 0xFAFAF7);
  cairo_fill(cr);
  cairo_set_line_width(cr, std::max(1.0, 0.9 * u));
  for (std::size_t k = 0; k < L.pzt.values.size(); ++k) {  // light grid and z labels
    const double yv = Y(L.pzt.values[k]);
    cairo_move_to(cr, left, yv);
    cairo_line_to(cr, left + w, yv);
    setColour(cr, 0xE3E1DA);
    cairo_stroke(cr);
    drawText(cr, L.tick_font, kMutedInk, L.pzt.labels[k], left - L.tick_len - 4 * u,
             yv + 0.36 * L.tick_font.size, 1.0);
  }
  for (std::size_t k = 0; k < L.pst.values.size(); ++k) {
    const double xv = X(L.pst.values[k]);
    cairo_move_to(cr, xv, top + h);
    cairo_line_to(cr, xv, top + h + L.tick_len);
    setColour(cr, kFrame);
    cairo_stroke(cr);
    drawText(cr, L.tick_font, kMutedInk, L.pst.labels[k], xv, L.prof_xlabel_base, 0.5);
  }
  cairo_save(cr);
  cairo_rectangle(cr, left, top, w, h);
  cairo_clip(cr);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (const ProfileSeries& ser : P.series) {
    if (ser.s_m.size() < 2) continue;
    setDash(cr, ser.dashed, u);
    cairo_move_to(cr, X(ser.s_m[0]), Y(ser.z_m[0]));
    for (std::size_t k = 1; k < ser.s_m.size(); ++k) cairo_line_to(cr, X(ser.s_m[k]), Y(ser.z_m[k]));
    setColour(cr, ser.colour);
    cairo_set_line_width(cr, ser.width_px * u);
    cairo_stroke(cr);
  }
  setDash(cr, false, u);
  std::vector<LabelAnchor> anchors;
  for (std::size_t i = 0; i < P.labels.size(); ++i) {
    const ProfileLabel& lab = P.labels[i];
    drawMarkerGlyph(cr, MarkerShape::kCircle, kFigureBreakPoint, X(lab.s_m), Y(lab.z_m), 7 * u, u);
    LabelAnchor a;
    a.x = X(lab.s_m);
    a.y = Y(lab.z_m);
    a.radius = 3.5 * u;
    a.text = lab.text;
    a.priority = lab.priority;
    a.group = lab.priority <= 0 ? -1 : 0;
    a.sequence = static_cast<int>(i);
    anchors.push_back(std::move(a));
  }
  addLabelCounts(drawLabels(cr, Font{11.5 * u, true}, u, anchors, {left + u, top + u, left + w - u, top + h - u}),
                 counts);
  cairo_restore(cr);
  cairo_rectangle(cr, left - 0.5, top - 0.5, w + 1, h + 1);
  setColour(cr, kFrame);
  cairo_set_line_width(cr, 1.0);
  cairo_stroke(cr);
}

/// Everything but the raster; `raster`, when given, is painted into the map area first.
void drawPicture(cairo_t* cr, const Layout& L, cairo_surface_t* raster, const Overlays& ov, LabelCounts& counts) {
  setupText(cr);
  if (raster) {
    cairo_save(cr);
    cairo_rectangle(cr, L.map_left, L.map_top, L.mw, L.mh);
    cairo_clip(cr);
    cairo_set_source_surface(cr, raster, L.map_left, L.map_top);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
    cairo_restore(cr);
  } else if (!L.has_map) {
    cairo_rectangle(cr, L.map_left, L.map_top, L.mw, L.mh);
    setColour(cr, kOpenSpace);
    cairo_fill(cr);
  }
  drawOverlays(cr, L, ov, counts);
  if (!L.title.empty()) drawText(cr, L.title_font, kInk, L.title, L.margin, L.title_base);
  drawText(cr, L.caption_font, kMutedInk, L.caption, L.margin, L.caption_base);
  drawAxes(cr, L);
  drawNorthArrow(cr, L);
  drawLegend(cr, L);
  drawScaleBar(cr, L);
  drawProfile(cr, L, counts);
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

// ---- SVG ------------------------------------------------------------------------------------------
// An SVG is assembled from three layers: the map as vector rectangles (`<g id="map">`), Cairo's
// drawing of the overlays and annotations with the map area left transparent (`<g id="drawing">`),
// and the text as <text> elements (`<g id="text">`), so a surveyor can select, search and restyle
// labels, and hide or recolour the map in an editor.

std::string svgColour(std::uint32_t c) {
  char b[8];
  std::snprintf(b, sizeof b, "#%06X", static_cast<unsigned>(c & 0xFFFFFFu));
  return b;
}

/// Device pixels to two decimals, trailing zeros dropped.
std::string svgNumber(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  std::string t(b);
  while (!t.empty() && t.back() == '0') t.pop_back();
  if (!t.empty() && t.back() == '.') t.pop_back();
  return t == "-0" ? "0" : t;
}

/// The raster (`w` x `h` pixels, 0x00RRGGBB) as rectangles at (left, top): runs of one colour in a
/// row, merged with equal runs in the rows below; one path per colour over a rock-coloured ground.
void appendMapLayer(std::string& out, const std::uint32_t* base, std::size_t stride, int w, int h, int left, int top) {
  struct Rect {
    int x, y, w, h;
    std::uint32_t c;
  };
  std::vector<Rect> rects;
  // (first column, end column, colour) of a run -> its rectangle in the row above
  std::unordered_map<std::uint64_t, std::size_t> above, here;
  const bool merge = w < (1 << 20);  // the key's room for columns
  for (int r = 0; r < h; ++r) {
    here.clear();
    const std::uint32_t* row = base + static_cast<std::size_t>(r) * stride;
    for (int i = 0; i < w;) {
      const std::uint32_t c = row[i] & 0xFFFFFFu;
      int j = i + 1;
      while (j < w && (row[j] & 0xFFFFFFu) == c) ++j;
      if (c != kTopViewBackground) {
        const std::uint64_t key =
            (static_cast<std::uint64_t>(i) << 44) | (static_cast<std::uint64_t>(j) << 24) | c;
        const auto it = merge ? above.find(key) : above.end();
        if (it != above.end()) {
          ++rects[it->second].h;
          here.emplace(key, it->second);
        } else {
          if (merge) here.emplace(key, rects.size());
          rects.push_back({i, r, j - i, 1, c});
        }
      }
      i = j;
    }
    above.swap(here);
  }
  std::stable_sort(rects.begin(), rects.end(), [](const Rect& a, const Rect& b) { return a.c < b.c; });
  out += "<g id=\"map\" shape-rendering=\"crispEdges\">\n<rect x=\"" + std::to_string(left) + "\" y=\"" +
         std::to_string(top) + "\" width=\"" + std::to_string(w) + "\" height=\"" + std::to_string(h) +
         "\" fill=\"" + svgColour(kTopViewBackground) + "\"/>\n";
  for (std::size_t k = 0; k < rects.size();) {
    const std::uint32_t c = rects[k].c;
    out += "<path fill=\"" + svgColour(c) + "\" d=\"";
    for (; k < rects.size() && rects[k].c == c; ++k) {
      const Rect& q = rects[k];
      out += "M" + std::to_string(left + q.x) + " " + std::to_string(top + q.y) + "h" + std::to_string(q.w) + "v" +
             std::to_string(q.h) + "h-" + std::to_string(q.w) + "z";
    }
    out += "\"/>\n";
  }
  out += "</g>\n";
}

void appendTextLayer(std::string& out, const std::vector<SvgText>& texts) {
  // preserve: the captions space their parts with runs of blanks
  out += "<g id=\"text\" font-family=\"sans-serif\" xml:space=\"preserve\">\n";
  for (const SvgText& t : texts) {
    out += "<text x=\"" + svgNumber(t.x) + "\" y=\"" + svgNumber(t.y) + "\" font-size=\"" + svgNumber(t.font.size) +
           "\"";
    if (t.font.bold) out += " font-weight=\"bold\"";
    if (t.align >= 0.75) {
      out += " text-anchor=\"end\"";
    } else if (t.align >= 0.25) {
      out += " text-anchor=\"middle\"";
    }
    out += " fill=\"" + svgColour(t.colour) + "\"";
    if (t.halo) {
      out += " stroke=\"" + svgColour(kPage) + "\" stroke-opacity=\"0.85\" stroke-width=\"" +
             svgNumber(0.3 * t.font.size) + "\" stroke-linejoin=\"round\" paint-order=\"stroke\"";
    }
    out += ">" + htmlEscape(t.text) + "</text>\n";
  }
  out += "</g>\n";
}

/// The whole document: `drawing` is Cairo's SVG of everything but the map and the text.
std::string assembleSvg(const Layout& L, const std::string& map_layer, const std::string& drawing,
                        const std::vector<SvgText>& texts) {
  const std::string w = std::to_string(L.width), h = std::to_string(L.height);
  std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    w + "\" height=\"" + h + "\" viewBox=\"0 0 " + w + " " + h + "\">\n<title>" +
                    htmlEscape(L.title.empty() ? std::string("adit picture") : L.title) + "</title>\n";
  out += map_layer;
  const std::size_t root = drawing.find("<svg");
  out += "<g id=\"drawing\">\n";
  out += root == std::string::npos ? drawing : drawing.substr(root);
  out += "</g>\n";
  appendTextLayer(out, texts);
  out += "</svg>\n";
  return out;
}

Status validateOptions(const TopViewOptions& o) {
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
  return {};
}

Status validatePath(const std::string& path) {
  const std::string ext = lowerExtension(path);
  if (ext.empty()) return adit::invalidArgument(path + ": no file extension; use .png or .svg");
  if (ext != ".png" && ext != ".svg")
    return adit::invalidArgument(path + ": unknown picture format '" + ext + "'; use .png or .svg");
  // Fail before the work when the file cannot be placed (writeFileAtomically checks again).
  const std::filesystem::path target(path);
  const std::filesystem::path dir = target.has_parent_path() ? target.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    return adit::notFound(path + ": directory '" + dir.string() + "' does not exist");
  return {};
}

Status badOverlay(const std::string& what, std::size_t index, const std::string& why) {
  return adit::invalidArgument("figure: " + what + " " + std::to_string(index) + ": " + why);
}

bool finitePositive(double v) { return std::isfinite(v) && v > 0; }

Status validateOverlays(const Overlays& ov, const std::optional<SideProfile>& profile) {
  for (std::size_t i = 0; i < ov.lines.size(); ++i) {
    const FigureLine& l = ov.lines[i];
    for (const Vec3& p : l.points)
      if (!map::allFinite(p)) return badOverlay("line", i, "a point is not finite");
    if (!l.values.empty() && l.values.size() != l.points.size())
      return badOverlay("line", i, std::to_string(l.values.size()) + " values for " +
                                       std::to_string(l.points.size()) + " points");
    for (double v : l.values)
      if (!std::isfinite(v)) return badOverlay("line", i, "a value is not finite");
    if (!finitePositive(l.width_px)) return badOverlay("line", i, "width_px must be finite and > 0");
  }
  for (std::size_t i = 0; i < ov.markers.size(); ++i) {
    if (!map::allFinite(ov.markers[i].position)) return badOverlay("marker", i, "position is not finite");
    if (!finitePositive(ov.markers[i].size_px)) return badOverlay("marker", i, "size_px must be finite and > 0");
  }
  for (std::size_t i = 0; i < ov.discs.size(); ++i) {
    if (!map::allFinite(ov.discs[i].center)) return badOverlay("disc", i, "centre is not finite");
    if (!finitePositive(ov.discs[i].radius_m)) return badOverlay("disc", i, "radius_m must be finite and > 0");
    if (!(ov.discs[i].fill_alpha >= 0 && ov.discs[i].fill_alpha <= 1))
      return badOverlay("disc", i, "fill_alpha must be in [0, 1]");
  }
  if (profile) {
    if (!finitePositive(profile->height_px)) return adit::invalidArgument("figure: profile height_px must be > 0");
    for (std::size_t i = 0; i < profile->series.size(); ++i) {
      const ProfileSeries& ser = profile->series[i];
      if (ser.s_m.size() != ser.z_m.size())
        return badOverlay("profile series", i, "s_m and z_m differ in length");
      for (std::size_t k = 0; k < ser.s_m.size(); ++k)
        if (!std::isfinite(ser.s_m[k]) || !std::isfinite(ser.z_m[k]))
          return badOverlay("profile series", i, "a value is not finite");
      if (!finitePositive(ser.width_px)) return badOverlay("profile series", i, "width_px must be > 0");
    }
    for (std::size_t i = 0; i < profile->labels.size(); ++i)
      if (!std::isfinite(profile->labels[i].s_m) || !std::isfinite(profile->labels[i].z_m))
        return badOverlay("profile label", i, "position is not finite");
  }
  return {};
}

/// The world extent of the overlays (x-y), or an empty box.
Aabb overlayExtent(const Overlays& ov) {
  Aabb b;
  for (const FigureLine& l : ov.lines)
    for (const Vec3& p : l.points) b.extend(p);
  for (const FigureMarker& m : ov.markers) b.extend(m.position);
  for (const FigureDisc& d : ov.discs) {
    b.extend(Vec3(d.center.array() - d.radius_m));
    b.extend(Vec3(d.center.array() + d.radius_m));
  }
  return b;
}

std::vector<LegendItem> legendItems(const Overlays& ov) {
  std::vector<LegendItem> items;
  // aggregate initialisation in the order of LegendItem: kind, colour, stroke, dashed, shape, alpha, text
  for (const FigureLine& l : ov.lines)
    if (!l.legend.empty())
      items.push_back({GlyphKind::kLine, l.values.empty() ? l.colour : valueColour(0.6), 0, l.dashed,
                       MarkerShape::kCircle, 1.0, l.legend});
  for (const FigureDisc& d : ov.discs)
    if (!d.legend.empty())
      items.push_back({GlyphKind::kDisc, d.fill, d.stroke, false, MarkerShape::kCircle, d.fill_alpha, d.legend});
  for (const FigureMarker& m : ov.markers)
    if (!m.legend.empty()) items.push_back({GlyphKind::kMarker, m.colour, 0, false, m.shape, 1.0, m.legend});
  return items;
}

}  // namespace

Figure::Figure(TopViewOptions options) : options_(std::move(options)) {}
void Figure::setMap(const OccupancyMap* map) { map_ = map; }
void Figure::setWorldBounds(const Aabb& bounds) { bounds_ = bounds; }
void Figure::addLine(FigureLine line) { lines_.push_back(std::move(line)); }
void Figure::addMarker(FigureMarker marker) { markers_.push_back(std::move(marker)); }
void Figure::addDisc(FigureDisc disc) { discs_.push_back(std::move(disc)); }
void Figure::setProfile(SideProfile profile) { profile_ = std::move(profile); }

Status Figure::render(const std::string& path, TopViewInfo* info) const {
  ADIT_RETURN_IF_ERROR(validatePath(path));
  return draw(lowerExtension(path) == ".svg" ? Output::kSvg : Output::kPng, path, nullptr, info);
}

Status Figure::renderPng(std::vector<unsigned char>* png, TopViewInfo* info) const {
  if (!png) return adit::invalidArgument("figure: renderPng needs an output buffer");
  return draw(Output::kPng, "", png, info);
}

Status Figure::draw(Output kind, const std::string& path, std::vector<unsigned char>* png, TopViewInfo* info) const {
  const std::string name = path.empty() ? std::string("figure") : path;
  ADIT_RETURN_IF_ERROR(validateOptions(options_));
  const Overlays ov{lines_, markers_, discs_};
  ADIT_RETURN_IF_ERROR(validateOverlays(ov, profile_));
  Content C;
  C.map = map_;
  if (map_) {
    C.bounds = map_->bounds();
    if (C.bounds.empty() || !map::allFinite(C.bounds.min) || !map::allFinite(C.bounds.max))
      return adit::failedPrecondition("top view: the map has no known voxel to draw");
    if (options_.view_box_m) {
      const Aabb& v = *options_.view_box_m;
      if (!map::allFinite(v.min) || !map::allFinite(v.max))
        return adit::invalidArgument("top view: view_box_m is not finite");
      for (int a = 0; a < 2; ++a) {
        C.bounds.min[a] = std::max(C.bounds.min[a], v.min[a]);
        C.bounds.max[a] = std::min(C.bounds.max[a], v.max[a]);
      }
      if (C.bounds.empty()) return adit::invalidArgument("top view: view_box_m does not overlap the map");
    }
  } else {
    if (bounds_ && !bounds_->empty()) {
      if (!map::allFinite(bounds_->min) || !map::allFinite(bounds_->max))
        return adit::invalidArgument("figure: world bounds are not finite");
      C.bounds = *bounds_;
    } else {
      C.bounds = overlayExtent(ov);
      if (C.bounds.empty()) return adit::failedPrecondition("figure: nothing to draw (no map, no bounds, no overlay)");
      // a margin so that nothing sits on the frame, and a minimum size for a single point
      const Vec3 sz = C.bounds.size();
      const double margin = std::max(1.0, 0.06 * std::max(sz.x(), sz.y()));
      C.bounds = C.bounds.inflated(margin);
    }
  }
  C.items = legendItems(ov);
  C.value_ramp = valueRange(lines_);
  C.profile = profile_ ? &*profile_ : nullptr;
  const bool svg = kind == Output::kSvg;

  // Measure on a scratch surface, with a first layout to size the raster.
  SurfacePtr scratch(cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1));
  ContextPtr mcr(cairo_create(scratch.get()));
  if (cairo_status(mcr.get()) != CAIRO_STATUS_SUCCESS)
    return cairoFailure(name, "create a drawing context", cairo_status(mcr.get()));
  setupText(mcr.get());
  Layout L;
  bool raised = false;
  ADIT_RETURN_IF_ERROR(computeLayout(C, options_, mcr.get(), L, raised, nullptr));

  // The raster: straight into the picture for PNG, a separate image to embed for SVG.
  SurfacePtr picture, raster;
  RasterStats stats;
  if (!svg) {
    picture.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24, L.width, L.height));
    if (cairo_surface_status(picture.get()) != CAIRO_STATUS_SUCCESS)
      return cairoFailure(name, "allocate the picture", cairo_surface_status(picture.get()));
    if (map_) {
      cairo_surface_flush(picture.get());
      auto* data = cairo_image_surface_get_data(picture.get());
      const std::size_t stride = cairo_image_surface_get_stride(picture.get()) / 4;
      std::uint32_t* base = reinterpret_cast<std::uint32_t*>(data) + L.map_top * stride + L.map_left;
      stats = rasterise(*map_, options_, L, base, stride);
      cairo_surface_mark_dirty(picture.get());
    }
  } else if (map_) {
    raster.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24, L.mw, L.mh));
    if (cairo_surface_status(raster.get()) != CAIRO_STATUS_SUCCESS)
      return cairoFailure(name, "allocate the raster", cairo_surface_status(raster.get()));
    cairo_surface_flush(raster.get());
    const std::size_t stride = cairo_image_surface_get_stride(raster.get()) / 4;
    stats = rasterise(*map_, options_, L, reinterpret_cast<std::uint32_t*>(cairo_image_surface_get_data(raster.get())),
                      stride);
    cairo_surface_mark_dirty(raster.get());
  }
  // Final layout with the real floor range. Its geometry nearly always equals the first one's (the
  // legend was sized for the map's height range); when it does not, e.g. a flat map whose ramp
  // becomes one swatch, the map area moves into a picture of the final size.
  Layout final_layout;
  ADIT_RETURN_IF_ERROR(computeLayout(C, options_, mcr.get(), final_layout, raised, map_ ? &stats : nullptr));
  if (final_layout.width != L.width || final_layout.height != L.height || final_layout.map_left != L.map_left ||
      final_layout.map_top != L.map_top) {
    if (!svg) {
      SurfacePtr resized(cairo_image_surface_create(CAIRO_FORMAT_RGB24, final_layout.width, final_layout.height));
      if (cairo_surface_status(resized.get()) != CAIRO_STATUS_SUCCESS)
        return cairoFailure(name, "allocate the picture", cairo_surface_status(resized.get()));
      ContextPtr cr(cairo_create(resized.get()));
      cairo_set_operator(cr.get(), CAIRO_OPERATOR_SOURCE);
      cairo_set_source_surface(cr.get(), picture.get(), final_layout.map_left - L.map_left,
                               final_layout.map_top - L.map_top);
      cairo_rectangle(cr.get(), final_layout.map_left, final_layout.map_top, L.mw, L.mh);
      cairo_fill(cr.get());
      if (cairo_status(cr.get()) != CAIRO_STATUS_SUCCESS)
        return cairoFailure(name, "copy the raster", cairo_status(cr.get()));
      cr.reset();
      picture = std::move(resized);
    }
  }
  L = final_layout;

  cairo_status_t cst = CAIRO_STATUS_SUCCESS;
  const char* stage = "draw";
  LabelCounts counts;
  Status written;
  if (!svg) {
    {
      ContextPtr cr(cairo_create(picture.get()));
      fillPage(cr.get(), L, /*skip_map_area=*/map_ != nullptr);
      drawPicture(cr.get(), L, nullptr, ov, counts);
      cst = cairo_status(cr.get());
    }
    if (cst != CAIRO_STATUS_SUCCESS) return cairoFailure(name, "draw the picture", cst);
    cairo_surface_flush(picture.get());
    stage = "encode the PNG";
    if (png) {
      std::ostringstream os;
      cst = cairo_surface_write_to_png_stream(picture.get(), writeToStream, &os);
      if (cst != CAIRO_STATUS_SUCCESS) return cairoFailure(name, stage, cst);
      const std::string bytes = os.str();
      png->assign(bytes.begin(), bytes.end());
    } else {
      written = map::writeFileAtomically(path, [&](std::ostream& os) {
        cst = cairo_surface_write_to_png_stream(picture.get(), writeToStream, &os);
        return cst == CAIRO_STATUS_SUCCESS;
      });
    }
  } else {
    stage = "write the SVG";
    std::string map_layer;
    if (raster) {
      const std::size_t stride = cairo_image_surface_get_stride(raster.get()) / 4;
      appendMapLayer(map_layer, reinterpret_cast<const std::uint32_t*>(cairo_image_surface_get_data(raster.get())),
                     stride, std::min(L.mw, cairo_image_surface_get_width(raster.get())),
                     std::min(L.mh, cairo_image_surface_get_height(raster.get())), L.map_left, L.map_top);
    }
    std::vector<SvgText> texts;
    std::ostringstream drawing;
    {
      SurfacePtr surface(cairo_svg_surface_create_for_stream(writeToStream, &drawing, L.width, L.height));
      cst = cairo_surface_status(surface.get());
      if (cst == CAIRO_STATUS_SUCCESS) {
        cairo_svg_surface_set_document_unit(surface.get(), CAIRO_SVG_UNIT_PX);
        {
          ContextPtr cr(cairo_create(surface.get()));
          cairo_set_user_data(cr.get(), &kSvgTextKey, &texts, nullptr);
          fillPage(cr.get(), L, /*skip_map_area=*/map_ != nullptr);
          drawPicture(cr.get(), L, nullptr, ov, counts);
          cst = cairo_status(cr.get());
        }
        if (cst == CAIRO_STATUS_SUCCESS) {
          cairo_surface_finish(surface.get());
          cst = cairo_surface_status(surface.get());
        }
      }
    }
    if (cst != CAIRO_STATUS_SUCCESS) return cairoFailure(name, stage, cst);
    const std::string doc = assembleSvg(L, map_layer, drawing.str(), texts);
    written = map::writeFileAtomically(path, [&](std::ostream& os) {
      os.write(doc.data(), static_cast<std::streamsize>(doc.size()));
      return os.good();
    });
  }
  // A stream failure is the writer's to explain; any other Cairo failure is ours.
  if (cst != CAIRO_STATUS_SUCCESS && cst != CAIRO_STATUS_WRITE_ERROR) return cairoFailure(name, stage, cst);
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
    out.labels = counts.labels;
    out.labels_merged = counts.merged;
    out.label_leaders = counts.leaders;
    out.label_overlaps = counts.overlaps;
    *info = out;
  }
  return {};
}

Status renderTopView(const OccupancyMap& map, const TopViewOptions& options, const std::string& path,
                     TopViewInfo* info) {
  Figure fig(options);
  fig.setMap(&map);
  return fig.render(path, info);
}

}  // namespace adit::tools

#if defined(__SANITIZE_ADDRESS__)
// Fontconfig (under Cairo's text) keeps its process-lifetime configuration and pattern caches
// behind encoded pointers that LeakSanitizer cannot follow, so every binary that draws text would
// report them as leaks at exit. Weak, so that a binary with its own suppressions keeps them.
extern "C" __attribute__((weak)) const char* __lsan_default_suppressions() { return "leak:libfontconfig.so\n"; }
#endif
