// SPDX-License-Identifier: BSD-3-Clause
// The animated page of a run. The page is plain HTML with an inline script; the frames travel as
// one JSON block of integer arrays (millimetres and milliseconds, each series stored as the
// differences between consecutive values), which keeps a 3000-frame run with ten movers at a few
// hundred kilobytes: consecutive positions differ by a few centimetres, i.e. two or three digits.
// A Content-Security-Policy forbids every fetch, so the page cannot reach the network even if
// someone later edits it to; a blocked fetch is recorded like a script error.
#include "common/animation_page.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "adit/map/map_io.hpp"

namespace adit::tools {
namespace {

using adit::map::Vec3;
using nlohmann::json;

/// Coordinates beyond this are refused: far outside any mine, and the millimetre integers of the
/// page must stay exact in JavaScript's doubles (2^53).
constexpr double kMaxCoordinate_m = 1e7;
constexpr double kMaxTime_s = 1e9;
/// Seconds of the robot's most recent path drawn as the fading trail.
constexpr double kTrailSeconds = 8.0;

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// RFC 4648 base64 for the data: URL. None of the project's libraries exposes an encoder (Cairo
// writes PNG streams only), and this is the whole of it.
std::string base64(const std::vector<unsigned char>& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest > 0) {
    const std::uint32_t v = (bytes[i] << 16) | (rest == 2 ? bytes[i + 1] << 8 : 0);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += rest == 2 ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string cssColour(std::uint32_t rgb) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%06X", static_cast<unsigned>(rgb & 0xFFFFFF));
  return buf;
}

/// Status colours chosen apart from the figure's palette (start, goal, obstacles), so the robot
/// never looks like a marker of the picture; statuses the page does not know get the spares.
std::uint32_t knownStatusColour(const std::string& status, bool* known) {
  static const std::map<std::string, std::uint32_t> kColours = {
      {"following", 0x27AE60}, {"yielding", 0xF39C12}, {"detouring", 0x00A3C4},
      {"stuck", 0xE74C3C},     {"arrived", 0x1B5E20},  {"collision", 0x8B0000},
      {"timeout", 0x7F8C8D},   {"refused", 0x5D6D7E},  {"replanning", 0xC2185B},
      {"", 0x95A5A6}};
  const auto it = kColours.find(status);
  *known = it != kColours.end();
  return *known ? it->second : 0;
}
constexpr std::uint32_t kSpareStatusColours[] = {0x6C5CE7, 0xD35400, 0xE84393, 0x795548, 0x00B894};

std::string frameName(const AnimationPageInput& in, std::size_t i) {
  return "animation page: frame " + std::to_string(i) + " (t = " + num(in.frames[i].t_s) + " s)";
}

Status checkPoint(const Vec3& p, const std::string& where) {
  static const char* kAxes[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(p[k])) return invalidArgument(where + " " + kAxes[k] + " is " + num(p[k]));
    if (std::abs(p[k]) > kMaxCoordinate_m) {
      return outOfRange(where + " " + kAxes[k] + " = " + num(p[k]) + " m is beyond +-" +
                        num(kMaxCoordinate_m) + " m");
    }
  }
  return {};
}

Status checkView(const std::vector<unsigned char>& png, const TopViewInfo& v) {
  static constexpr unsigned char kSignature[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (png.size() < sizeof kSignature || !std::equal(std::begin(kSignature), std::end(kSignature), png.begin())) {
    return invalidArgument("animation page: the background is not a PNG (" + std::to_string(png.size()) + " bytes)");
  }
  if (v.width_px <= 0 || v.height_px <= 0) {
    return invalidArgument("animation page: background size " + std::to_string(v.width_px) + " x " +
                           std::to_string(v.height_px) + " px is empty");
  }
  if (!(std::isfinite(v.pixels_per_m) && v.pixels_per_m > 0)) {
    return invalidArgument("animation page: background scale " + num(v.pixels_per_m) + " px/m is not positive");
  }
  if (!std::isfinite(v.x_min_m) || !std::isfinite(v.y_max_m)) {
    return invalidArgument("animation page: background origin (" + num(v.x_min_m) + ", " + num(v.y_max_m) +
                           ") is not finite");
  }
  return {};
}

/// Integer samples stored as differences from the previous one (the first from zero).
class DeltaSeries {
 public:
  explicit DeltaSeries(double scale) : scale_(scale) {}
  void push(double v) {
    const long long q = std::llround(v * scale_);
    values_.push_back(q - last_);
    last_ = q;
  }
  json toJson() const { return json(values_); }

 private:
  double scale_;
  long long last_ = 0;
  std::vector<long long> values_;
};

/// The frame an event belongs to: the first at or after its time (the last one for an event after
/// the run's last frame). Times are compared at the page's millisecond.
std::size_t eventFrame(const AnimationPageInput& in, double t_s) {
  const auto it = std::lower_bound(in.frames.begin(), in.frames.end(), t_s - 5e-4,
                                   [](const PageFrame& f, double t) { return f.t_s < t; });
  return it == in.frames.end() ? in.frames.size() - 1 : static_cast<std::size_t>(it - in.frames.begin());
}

/// The short tag drawn on a mover and beside its legend entry: the number its name ends in
/// ("obstacle 4" is 4, as the paper numbers them), a short name as it is ("a"), otherwise its
/// place in the list. All tags come from one rule, and from the list places when two would clash.
std::vector<std::string> moverTags(const std::vector<PageMover>& movers) {
  std::vector<std::string> tags;
  for (std::size_t k = 0; k < movers.size(); ++k) {
    const std::string& name = movers[k].name;
    std::size_t digits = name.size();
    while (digits > 0 && std::isdigit(static_cast<unsigned char>(name[digits - 1]))) --digits;
    if (digits < name.size() && name.size() - digits <= 4) tags.push_back(name.substr(digits));
    else if (!name.empty() && name.size() <= 3) tags.push_back(name);
    else tags.push_back(std::to_string(k + 1));
  }
  std::vector<std::string> sorted = tags;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    for (std::size_t k = 0; k < tags.size(); ++k) tags[k] = std::to_string(k + 1);
  return tags;
}

/// A time-stamped point list (and a path) as per-series differences, like the frames.
json pointSeries(const std::vector<PagePoint>& points) {
  DeltaSeries t(1000), x(1000), y(1000);
  for (const PagePoint& p : points) {
    t.push(p.t_s);
    x.push(p.p.x());
    y.push(p.p.y());
  }
  return {{"t", t.toJson()}, {"x", x.toJson()}, {"y", y.toJson()}};
}
json pathSeries(const std::vector<Vec3>& path) {
  DeltaSeries x(1000), y(1000);
  for (const Vec3& p : path) {
    x.push(p.x());
    y.push(p.y());
  }
  return {{"x", x.toJson()}, {"y", y.toJson()}};
}

json frameData(const TopViewInfo& view, const AnimationPageInput& in,
               std::vector<std::pair<std::string, std::uint32_t>>* statuses) {
  DeltaSeries t(1000), rx(1000), ry(1000), rz(1000), ryaw(1000);
  const bool box = in.boxRobot();
  double last_yaw = 0.0;  // unwrapped, so that a turn through +-pi interpolates the short way
  std::vector<DeltaSeries> mx(in.movers.size(), DeltaSeries(1000)), my(in.movers.size(), DeltaSeries(1000));
  std::vector<long long> status_runs;  // frame index, status index, ...
  std::map<std::string, std::size_t> status_index;
  std::size_t spare = 0;
  // An event's moment shows its status (a replan's "replanning") on its frame.
  std::map<std::size_t, std::string> event_status;
  for (const PageEvent& e : in.events)
    if (!e.status.empty()) event_status[eventFrame(in, e.t_s)] = e.status;
  for (std::size_t i = 0; i < in.frames.size(); ++i) {
    const PageFrame& f = in.frames[i];
    const auto over = event_status.find(i);
    const std::string& status = over == event_status.end() ? f.status : over->second;
    t.push(f.t_s);
    rx.push(f.robot.x());
    ry.push(f.robot.y());
    rz.push(f.robot.z());
    if (box) {
      const double yaw = std::isfinite(f.yaw) ? f.yaw : last_yaw;
      last_yaw = i == 0 ? yaw : last_yaw + std::remainder(yaw - last_yaw, 2.0 * 3.14159265358979323846);
      ryaw.push(last_yaw);
    }
    for (std::size_t m = 0; m < in.movers.size(); ++m) {
      mx[m].push(f.movers[m].x());
      my[m].push(f.movers[m].y());
    }
    auto it = status_index.find(status);
    if (it == status_index.end()) {
      bool known = false;
      std::uint32_t colour = knownStatusColour(status, &known);
      if (!known) colour = kSpareStatusColours[spare++ % std::size(kSpareStatusColours)];
      it = status_index.emplace(status, statuses->size()).first;
      statuses->emplace_back(status, colour);
    }
    const long long s = static_cast<long long>(it->second);
    if (status_runs.empty() || status_runs.back() != s) {
      status_runs.push_back(static_cast<long long>(i));
      status_runs.push_back(s);
    }
  }
  json d;
  d["version"] = 1;
  d["view"] = {{"w", view.width_px},          {"h", view.height_px},          {"left", view.map_left_px},
               {"top", view.map_top_px},      {"mw", view.map_width_px},      {"mh", view.map_height_px},
               {"ppm", view.pixels_per_m},    {"xmin", view.x_min_m},         {"ymax", view.y_max_m}};
  d["trail_s"] = kTrailSeconds;
  d["t"] = t.toJson();
  d["robot"] = {{"r", in.robot_radius_m}, {"x", rx.toJson()}, {"y", ry.toJson()}, {"z", rz.toJson()}};
  if (box) {
    d["robot"]["box"] = {in.robot_length_m, in.robot_width_m};
    d["robot"]["yaw"] = ryaw.toJson();
  }
  json names = json::array(), colours = json::array();
  for (const auto& [name, colour] : *statuses) {
    names.push_back(name);
    colours.push_back(cssColour(colour));
  }
  d["status"] = {{"names", names}, {"colours", colours}, {"runs", status_runs}};
  json movers = json::array();
  const std::vector<std::string> tags = moverTags(in.movers);
  for (std::size_t m = 0; m < in.movers.size(); ++m) {
    movers.push_back({{"r", in.movers[m].radius_m},
                      {"c", cssColour(in.movers[m].colour)},
                      {"tag", tags[m]},
                      {"x", mx[m].toJson()},
                      {"y", my[m].toJson()}});
  }
  d["movers"] = std::move(movers);
  // What appears during the run, each from its time: events (marks, falls, paths), sensed rock,
  // sub-goals. The picture holds none of it, so the page at t shows only what happened by t.
  d["initial_path"] = pathSeries(in.initial_path);
  json events = json::array();
  for (const PageEvent& e : in.events) {
    json ev{{"t", std::llround(e.t_s * 1000)}, {"f", eventFrame(in, e.t_s)}, {"kind", e.kind}};
    if (e.radius_m > 0) ev["disc"] = {{"x", std::llround(e.center.x() * 1000)},
                                      {"y", std::llround(e.center.y() * 1000)},
                                      {"r", std::llround(e.radius_m * 1000)}};
    if (!e.path.empty()) ev["path"] = pathSeries(e.path);
    events.push_back(std::move(ev));
  }
  d["events"] = std::move(events);
  d["sensed"] = pointSeries(in.sensed);
  d["subgoals"] = pointSeries(in.subgoals);
  return d;
}

/// JSON that is safe inside a <script> element: no "</script", no "<!--".
std::string scriptSafe(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    if (c == '<') out += "\\u003c";
    else out += c;
  }
  return out;
}

const char* kStyle = R"CSS(
:root { --ink:#1d2430; --muted:#5b6575; --line:#d8dde5; --panel:#ffffff; --bg:#eef1f5; --accent:#2E86DE; }
* { box-sizing:border-box; }
body { margin:0; font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif; color:var(--ink); background:var(--bg); }
header { padding:12px 20px; background:#1d2430; color:#fff; display:flex; align-items:baseline; gap:16px; flex-wrap:wrap; }
header h1 { margin:0; font-size:18px; font-weight:600; }
header .sub { color:#b8c2d0; font-size:13px; }
main { display:flex; gap:16px; padding:16px 20px; align-items:flex-start; flex-wrap:wrap; }
.stage { flex:1 1 640px; min-width:320px; background:var(--panel); border:1px solid var(--line); border-radius:8px; padding:10px; text-align:center; }
.figure { position:relative; display:inline-block; max-width:100%; line-height:0; vertical-align:top; }
.figure img { display:block; max-width:100%; max-height:calc(100vh - 150px); min-height:240px; width:auto; height:auto; }
.figure canvas { position:absolute; left:0; top:0; width:100%; height:100%; }
.controls { display:flex; align-items:center; gap:12px; padding:10px 2px 2px; text-align:left; }
.controls .track { flex:1; display:flex; flex-direction:column; gap:2px; }
.controls input[type=range] { width:100%; margin:0; accent-color:var(--accent); }
.marks { position:relative; height:14px; margin:2px 8px 0; }
.marks .mark { position:absolute; top:0; min-width:0; width:9px; height:14px; margin-left:-4px; padding:0; border:1px solid rgba(0,0,0,.45); border-radius:2px; cursor:pointer; opacity:.45; }
.marks .mark.past { opacity:1; }
.marks .mark.now { outline:2px solid #1d2430; outline-offset:1px; opacity:1; }
#event-list { margin:0; padding:0; list-style:none; max-height:220px; overflow:auto; }
#event-list li { margin:2px 0; }
#event-list .ev { min-width:0; width:100%; text-align:left; padding:2px 6px; border:1px solid var(--line); border-radius:5px; background:#fff; color:var(--ink); font-size:12px; }
#event-list .ev:hover { background:var(--bg); }
#event-list .ev.now { border-color:#1d2430; font-weight:600; }
#event-list .ev.future { color:var(--muted); }
#event-list .dot { display:inline-block; width:8px; height:8px; border-radius:2px; margin-right:6px; }
#timeline { height:6px; width:calc(100% - 16px); margin:0 8px; border-radius:3px; image-rendering:pixelated; }
button { font:inherit; min-width:88px; padding:5px 12px; border:1px solid #1f6fb8; border-radius:6px; background:var(--accent); color:#fff; cursor:pointer; }
button:hover { background:#1f6fb8; }
select { font:inherit; padding:3px 4px; border:1px solid var(--line); border-radius:5px; background:#fff; }
aside { flex:0 1 300px; min-width:260px; display:flex; flex-direction:column; gap:12px; }
@media (max-width: 980px) {
  aside { flex:1 1 100%; display:grid; grid-template-columns:repeat(auto-fill, minmax(260px, 1fr)); align-items:start; }
}
.panel { background:var(--panel); border:1px solid var(--line); border-radius:8px; padding:10px 12px; }
.panel h2 { margin:0 0 6px; font-size:12px; text-transform:uppercase; letter-spacing:.06em; color:var(--muted); }
#clock { font:600 28px/1.1 ui-monospace,"DejaVu Sans Mono",monospace; font-variant-numeric:tabular-nums; }
#clock-of { color:var(--muted); font-size:12px; margin:2px 0 8px; font-variant-numeric:tabular-nums; }
.badge { display:inline-block; padding:3px 10px; border-radius:999px; color:#fff; font-weight:600; font-size:13px; background:#95A5A6; }
table { border-collapse:collapse; width:100%; font-variant-numeric:tabular-nums; }
td { padding:2px 0; vertical-align:top; }
td:first-child { color:var(--muted); padding-right:10px; white-space:nowrap; }
td.num { text-align:right; font-family:ui-monospace,"DejaVu Sans Mono",monospace; }
.legend li { list-style:none; display:flex; align-items:center; gap:8px; margin:3px 0; }
.legend ul { margin:0; padding:0; }
.sw { flex:none; display:inline-block; width:14px; height:14px; border-radius:50%; border:2px solid rgba(0,0,0,.35); }
.sw.num { width:18px; height:18px; font:700 10px/14px system-ui,sans-serif; color:#3d2352; text-align:center; }
.sw.line { width:22px; height:0; border-radius:0; border:0; border-top:3px solid; }
.sw.fade { width:22px; height:4px; border-radius:2px; border:0; }
.legend .statuses { display:flex; flex-wrap:wrap; gap:4px; margin-top:6px; }
.legend .statuses .badge { font-size:11px; padding:1px 7px; }
.note { color:var(--muted); font-size:12px; margin-top:6px; }
#errors { margin:0; padding:8px; background:#fdecea; color:#8B0000; border:1px solid #f5c6cb; border-radius:6px; white-space:pre-wrap; font-size:12px; }
footer { padding:0 20px 16px; color:var(--muted); font-size:12px; }
kbd { font:11px ui-monospace,monospace; border:1px solid var(--line); border-bottom-width:2px; border-radius:4px; padding:0 4px; background:#fff; }
)CSS";

// Installed first, in <head>, so that an error anywhere later (even a syntax error in the main
// script) is recorded in the DOM, where the browser test and a reader can see it.
const char* kErrorScript = R"JS(
(function () {
  var root = document.documentElement, list = [];
  window.aditRecordError = function (msg) {
    list.push(String(msg));
    root.setAttribute('data-errors', String(list.length));
    var box = document.getElementById('errors');
    if (box) { box.hidden = false; box.textContent = list.join('\n'); }
  };
  window.addEventListener('error', function (e) {
    window.aditRecordError('script error: ' + e.message + ' (line ' + e.lineno + ')');
  });
  window.addEventListener('unhandledrejection', function (e) {
    window.aditRecordError('unhandled rejection: ' + e.reason);
  });
  document.addEventListener('securitypolicyviolation', function (e) {
    window.aditRecordError('blocked by the offline policy: ' + e.blockedURI + ' (' + e.violatedDirective + ')');
  });
})();
)JS";

const char* kMainScript = R"JS(
(function () {
  'use strict';
  var root = document.documentElement;
  var D = JSON.parse(document.getElementById('adit-data').textContent);
  var V = D.view;
  function undelta(a, scale) {
    var out = new Float64Array(a.length), acc = 0;
    for (var i = 0; i < a.length; ++i) { acc += a[i]; out[i] = acc / scale; }
    return out;
  }
  function cols(xs) { var o = new Float64Array(xs.length); for (var i = 0; i < xs.length; ++i) o[i] = V.left + (xs[i] - V.xmin) * V.ppm; return o; }
  function rows(ys) { var o = new Float64Array(ys.length); for (var i = 0; i < ys.length; ++i) o[i] = V.top + (V.ymax - ys[i]) * V.ppm; return o; }

  var T = undelta(D.t, 1000), n = T.length;
  var RX = undelta(D.robot.x, 1000), RY = undelta(D.robot.y, 1000), RZ = undelta(D.robot.z, 1000);
  var RC = cols(RX), RR = rows(RY), RKEEP = decimate(RC, RR);
  var BOX = D.robot.box || null, RYAW = BOX ? undelta(D.robot.yaw, 1000) : null;
  var movers = D.movers.map(function (m) {
    var x = undelta(m.x, 1000), y = undelta(m.y, 1000);
    var c = cols(x), r = rows(y);
    return { c: c, r: r, keep: decimate(c, r), radius: m.r * V.ppm, colour: m.c, tag: String(m.tag) };
  });
  // What appears during the run, each from its frame or time: events (their discs and paths),
  // the rock the sensor saw, the sub-goals. The picture under the canvases has none of it.
  function polyline(p) { return { c: cols(undelta(p.x, 1000)), r: rows(undelta(p.y, 1000)) }; }
  function timedPoints(s) { return { t: undelta(s.t, 1), c: cols(undelta(s.x, 1000)), r: rows(undelta(s.y, 1000)) }; }
  var EV = D.events.map(function (e) {
    var d = e.disc ? { c: cols([e.disc.x / 1000])[0], r: rows([e.disc.y / 1000])[0], radius: e.disc.r / 1000 * V.ppm } : null;
    return { t: e.t, f: e.f, kind: e.kind, disc: d, path: e.path ? polyline(e.path) : null };
  });
  // The expected paths in force one after the other: the initial one, then each replan's.
  var PATHS = [{ f: -1, line: polyline(D.initial_path) }];
  EV.forEach(function (e) { if (e.path) PATHS.push({ f: e.f, line: e.path }); });
  var SENSED = timedPoints(D.sensed), SUBGOALS = timedPoints(D.subgoals);
  function countUpTo(ts, t) {  // entries of the sorted ts at or before t
    var lo = 0, hi = ts.length;
    while (lo < hi) { var mid = (lo + hi) >> 1; if (ts[mid] <= t) lo = mid + 1; else hi = mid; }
    return lo;
  }
  function msOf(f) { return Math.round(T[f] * 1000) + 0.5; }
  function pathInForce(f) { var p = 0; while (p + 1 < PATHS.length && PATHS[p + 1].f <= f) ++p; return p; }

  var S = new Uint16Array(n), runs = D.status.runs;
  for (var k = 0; k < runs.length; k += 2) {
    var end = k + 2 < runs.length ? runs[k + 2] : n;
    for (var i = runs[k]; i < end; ++i) S[i] = runs[k + 1];
  }

  var $ = function (id) { return document.getElementById(id); };
  var tracks = $('tracks').getContext('2d'), live = $('live').getContext('2d');
  var slider = $('slider'), playBtn = $('play'), speedSel = $('speed');

  function rgba(hex, a) {
    var v = parseInt(hex.slice(1), 16);
    return 'rgba(' + (v >> 16 & 255) + ',' + (v >> 8 & 255) + ',' + (v & 255) + ',' + a + ')';
  }
  // Paths are drawn through the points at least a picture pixel apart (a 30000-frame run would
  // otherwise stroke 30000 segments per obstacle per redraw).
  function decimate(c, r) {
    var keep = [0], lc = c[0], lr = r[0];
    for (var i = 1; i < c.length; ++i) {
      if (Math.abs(c[i] - lc) + Math.abs(r[i] - lr) >= 1) { keep.push(i); lc = c[i]; lr = r[i]; }
    }
    return keep;
  }
  // From the first point through the kept points up to frame f, ending at (x, y).
  function pathTo(ctx, c, r, keep, f, x, y) {
    ctx.beginPath();
    ctx.moveTo(c[0], r[0]);
    for (var j = 1; j < keep.length && keep[j] <= f; ++j) ctx.lineTo(c[keep[j]], r[keep[j]]);
    ctx.lineTo(x, y);
    ctx.stroke();
  }
  function lerp(a, f, u) { return u > 0 ? a[f] + u * (a[f + 1] - a[f]) : a[f]; }
  function disc(ctx, x, y, radius, fill, stroke, width) {
    ctx.beginPath();
    ctx.arc(x, y, radius, 0, 2 * Math.PI);
    ctx.fillStyle = fill; ctx.fill();
    ctx.lineWidth = width; ctx.strokeStyle = stroke; ctx.stroke();
  }

  // Line widths, text and the smallest disc are given in screen pixels: the picture is often
  // shown smaller than its size (a 2000-pixel map in a 900-pixel column), so the canvas pixels
  // per screen pixel (K) scale them. World sizes (the discs' radii) scale with the picture.
  var K = 1;
  function measure() {
    var shown = live.canvas.clientWidth;
    K = shown > 0 ? Math.max(V.w / shown, 0.5) : 1;
  }
  // Everything moving stays inside the map area, off the picture's axes, legend and title.
  function clipToMap(ctx) {
    ctx.beginPath();
    if (V.mw > 0 && V.mh > 0) ctx.rect(V.left, V.top, V.mw, V.mh); else ctx.rect(0, 0, V.w, V.h);
    ctx.clip();
  }
  // The movers' routes still ahead of frame f, dashed, only when the viewer asks (the "ahead"
  // box): a replay shows what had happened by t, and the robot never knew where a mover would go.
  var aheadBox = $('ahead'), tracksInked = false;
  function drawTracks(f, u) {
    var want = aheadBox && aheadBox.checked && f >= 0;
    if (!want && !tracksInked) return;  // unticked: nothing to clear, every frame
    tracks.setTransform(1, 0, 0, 1, 0, 0);
    tracks.clearRect(0, 0, V.w, V.h);
    tracksInked = want;
    if (!want) return;
    tracks.save();
    clipToMap(tracks);
    tracks.lineCap = 'round'; tracks.lineJoin = 'round';
    tracks.setLineDash([6 * K, 5 * K]);
    tracks.lineWidth = 1.5 * K;
    movers.forEach(function (m) {
      tracks.strokeStyle = rgba(m.colour, 0.6);
      tracks.beginPath();
      tracks.moveTo(lerp(m.c, f, u), lerp(m.r, f, u));
      for (var j = 0; j < m.keep.length; ++j) if (m.keep[j] > f) tracks.lineTo(m.c[m.keep[j]], m.r[m.keep[j]]);
      tracks.lineTo(m.c[n - 1], m.r[n - 1]);
      tracks.stroke();
    });
    tracks.restore();
  }

  var TRAIL = D.trail_s, ROBOT_TRAIL = '#2E86DE', FADE_STEPS = 12;
  // Frame f, a fraction u of the way to frame f + 1 (playback moves smoothly between frames).
  function draw(f, u) {
    drawTracks(f, u);
    live.clearRect(0, 0, V.w, V.h);
    live.save();
    clipToMap(live);
    live.lineCap = 'round'; live.lineJoin = 'round';
    EV.forEach(function (e) {  // roof falls from their time on
      if (e.disc && e.f <= f) disc(live, e.disc.c, e.disc.r, Math.max(e.disc.radius, 3 * K), 'rgba(255,59,59,0.3)', '#FF3B3B', 1.5 * K);
    });
    var ns = countUpTo(SENSED.t, msOf(f)), side = Math.max(2.5 * K, 0.15 * V.ppm);
    live.fillStyle = 'rgba(93,64,55,0.85)';
    for (var q = 0; q < ns; ++q) live.fillRect(SENSED.c[q] - side / 2, SENSED.r[q] - side / 2, side, side);
    var cur = pathInForce(f);
    live.setLineDash([7 * K, 5 * K]);
    for (var p = 0; p <= cur; ++p) {
      var line = PATHS[p].line;
      if (line.c.length < 2) continue;
      live.lineWidth = (p === cur ? 2.5 : 1.5) * K;
      live.strokeStyle = p === cur ? '#E4572E' : 'rgba(228,87,46,0.45)';
      live.beginPath(); live.moveTo(line.c[0], line.r[0]);
      for (var j = 1; j < line.c.length; ++j) live.lineTo(line.c[j], line.r[j]);
      live.stroke();
    }
    live.setLineDash([]);
    var ng = countUpTo(SUBGOALS.t, msOf(f));
    for (var g = 0; g < ng; ++g) {  // crosses; the sub-goal in force larger
      var h = (g === ng - 1 ? 6 : 3) * K, gx = SUBGOALS.c[g], gy = SUBGOALS.r[g];
      live.lineWidth = (g === ng - 1 ? 2.5 : 1.5) * K;
      live.strokeStyle = g === ng - 1 ? '#2E86DE' : 'rgba(46,134,222,0.5)';
      live.beginPath(); live.moveTo(gx - h, gy - h); live.lineTo(gx + h, gy + h);
      live.moveTo(gx - h, gy + h); live.lineTo(gx + h, gy - h); live.stroke();
    }
    movers.forEach(function (m, k) {
      var x = lerp(m.c, f, u), y = lerp(m.r, f, u), r = Math.max(m.radius, 3 * K);
      live.lineWidth = 2 * K; live.strokeStyle = rgba(m.colour, 0.95);
      pathTo(live, m.c, m.r, m.keep, f, x, y);
      disc(live, x, y, r, rgba(m.colour, 0.6), m.colour, 1.5 * K);
      // Its number, as in the legend.
      live.font = '700 ' + (12 * K) + 'px system-ui, sans-serif';
      live.textBaseline = 'middle'; live.lineWidth = 3 * K; live.strokeStyle = 'rgba(255,255,255,0.9)';
      var lx = x + 0.75 * r + 3 * K, ly = y - 0.75 * r - 4 * K;
      live.strokeText(m.tag, lx, ly); live.fillStyle = '#3d2352'; live.fillText(m.tag, lx, ly);
    });
    var cx = lerp(RC, f, u), cy = lerp(RR, f, u), now = lerp(T, f, u);
    // The driven path so far, faint; the last TRAIL seconds on top, fading with age in steps
    // (one stroke per step, not per segment).
    live.lineWidth = 1.5 * K; live.strokeStyle = rgba(ROBOT_TRAIL, 0.45);
    pathTo(live, RC, RR, RKEEP, f, cx, cy);
    live.lineWidth = 3.5 * K;
    var step = 0, px = cx, py = cy;
    live.beginPath(); live.moveTo(px, py);
    for (var i = f; i >= 0 && now - T[i] <= TRAIL; --i) {
      var s = Math.min(FADE_STEPS - 1, Math.floor((now - T[i]) / TRAIL * FADE_STEPS));
      if (s !== step) {
        live.strokeStyle = rgba(ROBOT_TRAIL, 1 - (step + 0.5) / FADE_STEPS); live.stroke();
        live.beginPath(); live.moveTo(px, py); step = s;
      }
      live.lineTo(RC[i], RR[i]); px = RC[i]; py = RR[i];
    }
    live.strokeStyle = rgba(ROBOT_TRAIL, 1 - (step + 0.5) / FADE_STEPS); live.stroke();

    var colour = D.status.colours[S[f]], r = Math.max(D.robot.r * V.ppm, 4 * K);
    if (BOX) {
      // A ground robot's body: its box turned to its heading (canvas rows run south, so the
      // angle's sign flips), a tick from the centre to the front edge.
      var yaw = lerp(RYAW, f, u), hl = Math.max(BOX[0] * V.ppm / 2, 3 * K), hw = Math.max(BOX[1] * V.ppm / 2, 2 * K);
      live.save(); live.translate(cx, cy); live.rotate(-yaw);
      live.lineJoin = 'round';
      live.lineWidth = 3 * K; live.strokeStyle = '#ffffff'; live.strokeRect(-hl, -hw, 2 * hl, 2 * hw);
      live.fillStyle = colour; live.fillRect(-hl, -hw, 2 * hl, 2 * hw);
      live.lineWidth = 1.5 * K; live.strokeStyle = '#1d2430'; live.strokeRect(-hl, -hw, 2 * hl, 2 * hw);
      live.lineWidth = 2 * K; live.strokeStyle = '#ffffff';
      live.beginPath(); live.moveTo(0, 0); live.lineTo(hl, 0); live.stroke();
      live.restore();
      r = Math.max(hl, hw);
    } else {
      disc(live, cx, cy, r + 1.5 * K, '#ffffff', '#ffffff', 0);
      disc(live, cx, cy, r, colour, '#1d2430', 1.5 * K);
    }
    if (r < 6 * K) {  // a robot of a few pixels on a large map: a ring to find it by
      live.beginPath(); live.arc(cx, cy, r + 5 * K, 0, 2 * Math.PI);
      live.lineWidth = 2 * K; live.strokeStyle = colour; live.stroke();
    }
    var a = u > 0 || f === 0 ? f : f - 1, b = Math.min(a + 1, n - 1);
    var dx = RC[b] - RC[a], dy = RR[b] - RR[a], len = Math.hypot(dx, dy);
    if (!BOX && len > 1e-9) {  // heading tick, from the centre to the rim
      live.lineWidth = 2 * K; live.strokeStyle = '#ffffff';
      live.beginPath(); live.moveTo(cx, cy);
      live.lineTo(cx + dx / len * r, cy + dy / len * r); live.stroke();
    }
    live.restore();
  }
  function fmt(v, d) { return (Math.abs(v) < 0.5 * Math.pow(10, -d) ? 0 : v).toFixed(d); }
  function speedAt(f) {
    var a = f > 0 ? f - 1 : f, b = f > 0 ? f : Math.min(f + 1, n - 1), dt = T[b] - T[a];
    if (!(dt > 0)) return null;
    return Math.hypot(RX[b] - RX[a], RY[b] - RY[a], RZ[b] - RZ[a]) / dt;
  }
  var frame = -1, simT = T[0];
  // The timeline's marks and the event list: each seeks to its event's frame, paused.
  var marks = Array.prototype.slice.call(document.querySelectorAll('#marks .mark, #event-list .ev'));
  var shownPast = -1, shownHere = false;
  function show(f) {  // frame f exactly: picture and panel
    showPanel(f);
    draw(f, 0);
  }
  function showPanel(f) {
    frame = f;
    $('clock').textContent = 't = ' + fmt(T[f], 1) + ' s';
    $('clock-of').textContent = 'of ' + fmt(T[n - 1], 1) + ' s \u00b7 frame ' + (f + 1) + ' / ' + n;
    var badge = $('status'), name = D.status.names[S[f]];
    badge.textContent = name === '' ? '\u2014' : name;
    badge.style.background = D.status.colours[S[f]];
    $('rx').textContent = fmt(RX[f], 2); $('ry').textContent = fmt(RY[f], 2); $('rz').textContent = fmt(RZ[f], 2);
    var v = speedAt(f);
    $('rv').textContent = v === null ? '\u2014' : fmt(v, 2);
    if (movers.length > 0) {
      var best = -1, gap = Infinity;
      movers.forEach(function (m, k) {
        var g = Math.hypot(RC[f] - m.c[f], RR[f] - m.r[f]) / V.ppm - D.robot.r - D.movers[k].r;
        if (g < gap) { gap = g; best = k; }
      });
      $('near').textContent = fmt(gap, 2) + ' (' + movers[best].tag + ')';
      $('near').style.color = gap < 0 ? '#C0392B' : '';
    }
    slider.value = String(f);
    root.setAttribute('data-frame', String(f));
    root.setAttribute('data-time', T[f].toFixed(3));
    root.setAttribute('data-status', name);
    // What the picture shows at this frame, for tests and readers of the DOM.
    var here = [], past = 0, falls = 0;
    EV.forEach(function (e) {
      if (e.f > f) return;
      ++past;
      if (e.disc) ++falls;
      if (e.f === f) here.push(e.kind);
    });
    root.setAttribute('data-event', here.join(' '));
    root.setAttribute('data-events-past', String(past));
    root.setAttribute('data-paths', String(pathInForce(f)));
    root.setAttribute('data-falls', String(falls));
    root.setAttribute('data-sensed', String(countUpTo(SENSED.t, msOf(f))));
    root.setAttribute('data-subgoals', String(countUpTo(SUBGOALS.t, msOf(f))));
    if (past !== shownPast || here.length > 0 || shownHere) {
      marks.forEach(function (el) {
        var e = EV[Number(el.getAttribute('data-event'))];
        el.classList.toggle('past', e.f <= f);
        el.classList.toggle('future', e.f > f);
        el.classList.toggle('now', e.f === f);
      });
      shownPast = past; shownHere = here.length > 0;
    }
  }
  function frameAt(t) {  // last frame at or before t
    var lo = 0, hi = n - 1;
    if (t >= T[hi]) return hi;
    while (lo < hi) { var mid = (lo + hi + 1) >> 1; if (T[mid] <= t) lo = mid; else hi = mid - 1; }
    return lo;
  }

  var playing = false, lastWall = null, pending = false;
  function setPlaying(p) {
    playing = p; lastWall = null;
    playBtn.textContent = p ? '\u275a\u275a Pause' : '\u25b6 Play';
    root.setAttribute('data-playing', p ? '1' : '0');
    if (p) schedule();
  }
  function tick() {
    pending = false;
    if (!playing) return;
    var now = performance.now();
    if (lastWall !== null) simT += (now - lastWall) / 1000 * Number(speedSel.value);
    lastWall = now;
    if (simT >= T[n - 1]) { simT = T[n - 1]; show(n - 1); setPlaying(false); return; }
    var f = frameAt(simT);
    if (f !== frame) showPanel(f);
    draw(f, T[f + 1] > T[f] ? (simT - T[f]) / (T[f + 1] - T[f]) : 0);
    schedule();
  }
  // A timer, not requestAnimationFrame: a pending animation frame stalls a headless browser's
  // virtual clock (the browser test runs the page that way); 50 redraws a second are smooth.
  function schedule() {
    if (pending) return;
    pending = true;
    setTimeout(tick, 20);
  }

  playBtn.addEventListener('click', function () {
    if (!playing && frame >= n - 1) { simT = T[0]; show(0); }
    setPlaying(!playing);
  });
  marks.forEach(function (el) {
    el.addEventListener('click', function () {
      var e = EV[Number(el.getAttribute('data-event'))];
      if (!e) return;
      setPlaying(false); simT = T[e.f]; show(e.f);
      el.blur();  // space and the arrows go on working the player, not this mark
    });
  });
  slider.addEventListener('input', function () {
    var f = Number(slider.value); simT = T[f]; lastWall = null; show(f);
  });
  document.addEventListener('keydown', function (e) {
    if (e.target && e.target.tagName === 'SELECT') return;
    var f = null;
    if (e.key === ' ') { playBtn.click(); e.preventDefault(); return; }
    if (e.key === 'ArrowRight') f = Math.min(frame + 1, n - 1);
    else if (e.key === 'ArrowLeft') f = Math.max(frame - 1, 0);
    else if (e.key === 'Home') f = 0;
    else if (e.key === 'End') f = n - 1;
    if (f === null) return;
    e.preventDefault(); setPlaying(false); simT = T[f]; show(f);
  });

  // The status over the whole run, under the slider.
  (function () {
    var tl = $('timeline').getContext('2d'), w = tl.canvas.width, span = T[n - 1] - T[0];
    for (var i = 0; i < n; ++i) {
      var x0 = span > 0 ? (T[i] - T[0]) / span * w : 0;
      var x1 = i + 1 < n ? (span > 0 ? (T[i + 1] - T[0]) / span * w : w) : w;
      tl.fillStyle = D.status.colours[S[i]];
      tl.fillRect(Math.floor(x0), 0, Math.max(1, Math.ceil(x1) - Math.floor(x0)), 1);
    }
  })();
  measure();
  window.addEventListener('resize', function () {
    var before = K;
    measure();
    if (K !== before && frame >= 0) draw(frame, 0);
  });
  if (aheadBox) aheadBox.addEventListener('change', function () { if (frame >= 0) draw(frame, 0); });

  // Default speed: the smallest offered that plays the run in about half a minute.
  var duration = T[n - 1] - T[0], options = Array.prototype.slice.call(speedSel.options);
  var pick = options.find(function (o) { return Number(o.value) >= 1 && duration / Number(o.value) <= 30; });
  speedSel.value = (pick || options[options.length - 1]).value;

  // "#t=42.5": open paused at that time (for stills and links); otherwise play from the start.
  var m = /(?:^#|&)t=([-+0-9.eE]+)/.exec(location.hash);
  if (m && isFinite(Number(m[1]))) {
    simT = Math.min(Math.max(Number(m[1]), T[0]), T[n - 1]);
    show(frameAt(simT)); setPlaying(false);
  } else {
    show(0); setPlaying(n > 1);
  }
  root.setAttribute('data-ready', '1');
})();
)JS";

/// Mark colours by event kind; kinds the page does not know are drawn slate.
std::string eventColour(const std::string& kind) {
  static const std::map<std::string, std::uint32_t> kColours = {
      {"replan", 0xC2185B},    {"roof_fall", kFigureBlocked}, {"stuck", 0xE74C3C},   {"escape", 0xF39C12},
      {"arrived", 0x1B5E20},   {"no_route", 0x5D6D7E},        {"collision", 0x8B0000}, {"end", 0x1D2430},
      {"timeout", 0x7F8C8D}};
  const auto it = kColours.find(kind);
  return cssColour(it == kColours.end() ? 0x34495E : it->second);
}

std::string eventText(const PageEvent& e) {
  return "t = " + fixed(e.t_s, 1) + " s \xC2\xB7 " + e.kind + (e.label.empty() ? "" : ": " + e.label);
}

/// One clickable mark per event under the status strip, at its time along the run.
void appendMarks(std::string& html, const AnimationPageInput& in) {
  const double t0 = in.frames.front().t_s, span = in.frames.back().t_s - t0;
  html += "<div id=\"marks\" class=\"marks\" data-events=\"" + std::to_string(in.events.size()) + "\">";
  for (std::size_t k = 0; k < in.events.size(); ++k) {
    const PageEvent& e = in.events[k];
    const double at = span > 0 ? std::clamp((e.t_s - t0) / span, 0.0, 1.0) * 100.0 : 0.0;
    const std::string text = htmlEscape(eventText(e));
    html += "<button type=\"button\" class=\"mark\" data-event=\"" + std::to_string(k) + "\" data-kind=\"" +
            htmlEscape(e.kind) + "\" data-t=\"" + fixed(e.t_s, 3) + "\" data-frame=\"" +
            std::to_string(eventFrame(in, e.t_s)) + "\" style=\"left:" + fixed(at, 3) + "%;background:" +
            eventColour(e.kind) + "\" title=\"" + text + "\" aria-label=\"" + text + "\"></button>";
  }
  html += "</div>\n";
}

void appendStage(std::string& html, const std::vector<unsigned char>& png, const TopViewInfo& view,
                 const AnimationPageInput& in) {
  const std::size_t frames = in.frames.size();
  const std::string w = std::to_string(view.width_px), h = std::to_string(view.height_px);
  html += "<section class=\"stage\">\n<div class=\"figure\" style=\"max-width:" + w + "px\">\n"
          "<img id=\"bg\" alt=\"top view of the run\" width=\"" + w + "\" height=\"" + h +
          "\" src=\"data:image/png;base64,";
  html += base64(png);
  html += "\">\n<canvas id=\"tracks\" width=\"" + w + "\" height=\"" + h + "\"></canvas>\n"
          "<canvas id=\"live\" width=\"" + w + "\" height=\"" + h + "\"></canvas>\n</div>\n"
          "<div class=\"controls\">\n<button id=\"play\" type=\"button\">\xE2\x96\xB6 Play</button>\n"
          "<div class=\"track\"><input id=\"slider\" type=\"range\" min=\"0\" max=\"" +
          std::to_string(frames - 1) + "\" step=\"1\" value=\"0\" aria-label=\"frame\">\n"
          "<canvas id=\"timeline\" width=\"1000\" height=\"1\" title=\"status over time\"></canvas>\n";
  appendMarks(html, in);
  html += "</div>\n<label>speed <select id=\"speed\">";
  for (const char* s : {"0.25", "0.5", "1", "2", "5", "10", "20", "50", "100"}) {
    html += std::string("<option value=\"") + s + "\">" + s + "\xC3\x97</option>";
  }
  html += "</select></label>\n";
  if (!in.movers.empty())
    html += "<label title=\"draw each moving obstacle's route still ahead, dashed (the robot did not know "
            "it)\"><input id=\"ahead\" type=\"checkbox\"> routes ahead</label>\n";
  html += "</div>\n</section>\n";
}

void appendClockAndRobot(std::string& html, const AnimationPageInput& in) {
  html += "<div class=\"panel\"><h2>Clock</h2><div id=\"clock\">t = " + fixed(in.frames.front().t_s, 1) +
          " s</div><div id=\"clock-of\"></div><span id=\"status\" class=\"badge\"></span></div>\n"
          "<div class=\"panel\"><h2>Robot</h2><table>"
          "<tr><td>x [m]</td><td class=\"num\" id=\"rx\"></td></tr>"
          "<tr><td>y [m]</td><td class=\"num\" id=\"ry\"></td></tr>"
          "<tr><td>z [m]</td><td class=\"num\" id=\"rz\"></td></tr>"
          "<tr><td>speed [m/s]</td><td class=\"num\" id=\"rv\"></td></tr>";
  if (!in.movers.empty()) {
    html += "<tr><td>gap to obstacle [m]</td><td class=\"num\" id=\"near\"></td></tr></table>"
            "<div class=\"note\">gap: between the robot's disc and the nearest moving obstacle's (its number "
            "in brackets), in plan; red when they overlap</div>";
  } else {
    html += "</table>";
  }
  html += "</div>\n";
}

/// The events as a list beside the picture (their reasons are too long for the marks' tooltips
/// alone); each entry seeks like its mark.
void appendEventList(std::string& html, const AnimationPageInput& in) {
  if (in.events.empty()) return;
  html += "<div class=\"panel\"><h2>Events</h2><ol id=\"event-list\">\n";
  for (std::size_t k = 0; k < in.events.size(); ++k) {
    const PageEvent& e = in.events[k];
    html += "<li><button type=\"button\" class=\"ev\" data-event=\"" + std::to_string(k) + "\" data-kind=\"" +
            htmlEscape(e.kind) + "\" data-frame=\"" + std::to_string(eventFrame(in, e.t_s)) +
            "\"><span class=\"dot\" style=\"background:" + eventColour(e.kind) + "\"></span>" +
            htmlEscape(eventText(e)) + "</button></li>\n";
  }
  html += "</ol></div>\n";
}

void appendSummaryRows(std::string& html, const AnimationPageInput& in) {
  for (const auto& [key, value] : in.summary) {
    html += "<tr><td>" + htmlEscape(key) + "</td><td>" + htmlEscape(value) + "</td></tr>\n";
  }
}

void appendLegend(std::string& html, const AnimationPageInput& in,
                  const std::vector<std::pair<std::string, std::uint32_t>>& statuses) {
  html += "<div class=\"panel legend\"><h2>Legend</h2><ul>\n";
  const bool box = in.boxRobot();
  html += "<li><span class=\"sw\" style=\"background:" + cssColour(statuses.front().second) +
          (box ? ";border-radius:2px;width:16px;height:11px" : "") + "\"></span>robot, " +
          (box ? fixed(in.robot_length_m, 2) + " &times; " + fixed(in.robot_width_m, 2) + " m, turned to its heading"
               : "r = " + fixed(in.robot_radius_m, 2) + " m") +
          " (colour: status)</li>\n";
  html += "<li><span class=\"sw fade\" style=\"background:linear-gradient(90deg,rgba(46,134,222,0),#2E86DE)\"></span>"
          "trail, last " + fixed(kTrailSeconds, 0) + " s</li>\n";
  html += "<li><span class=\"sw line\" style=\"border-color:rgba(46,134,222,.4)\"></span>driven path</li>\n";
  bool replans = false, falls = false;
  for (const PageEvent& e : in.events) {
    replans = replans || !e.path.empty();
    falls = falls || e.radius_m > 0;
  }
  if (!in.initial_path.empty() || replans) {
    html += "<li><span class=\"sw line\" style=\"border-top-style:dashed;border-color:" + cssColour(kFigurePath) +
            "\"></span>expected path in force</li>\n";
  }
  if (replans) {
    html += "<li><span class=\"sw line\" style=\"border-top-style:dashed;border-color:" + cssColour(kFigurePath) +
            "73\"></span>expected path replaced by a replan</li>\n";
  }
  if (falls) {
    html += "<li><span class=\"sw\" style=\"background:" + cssColour(kFigureBlocked) + "66;border-color:" +
            cssColour(kFigureBlocked) + "\"></span>roof fall (from its time)</li>\n";
  }
  if (!in.sensed.empty()) {
    html += "<li><span class=\"sw\" style=\"border-radius:0;width:8px;height:8px;border:0;background:#5D4037\"></span>"
            "rock the sensor saw (from then on)</li>\n";
  }
  if (!in.subgoals.empty()) {
    html += "<li><span class=\"sw\" style=\"border-radius:0;border:0;background:none;color:" +
            cssColour(kFigureTrajectory) + ";font:700 14px/14px sans-serif\">\xC3\x97</span>"
            "sub-goals chosen so far (the one in force larger)</li>\n";
  }
  const std::vector<std::string> tags = moverTags(in.movers);
  for (std::size_t k = 0; k < in.movers.size(); ++k) {
    const PageMover& m = in.movers[k];
    const std::string c = cssColour(m.colour);
    html += "<li><span class=\"sw num\" style=\"background:" + c + "99;border-color:" + c + "\">" +
            htmlEscape(tags[k]) + "</span>" +
            htmlEscape(m.name.empty() ? std::string("moving obstacle") : m.name) + ", r = " +
            fixed(m.radius_m, 2) + " m</li>\n";
  }
  if (!in.movers.empty()) {
    html += "<li><span class=\"sw line\" style=\"border-top-style:solid;border-color:" +
            cssColour(in.movers.front().colour) + "\"></span>obstacle track so far; ticking \"routes ahead\" adds the "
            "rest, dashed</li>\n";
  }
  html += "</ul><div class=\"statuses\">";
  for (const auto& [name, colour] : statuses) {
    html += "<span class=\"badge\" style=\"background:" + cssColour(colour) + "\">" +
            htmlEscape(name.empty() ? std::string("(no status)") : name) + "</span>";
  }
  html += "</div><div class=\"note\">Map, static obstacles, start and goal: the picture's own legend. The page "
          "draws what happens during the run at its time.</div></div>\n";
}

}  // namespace

Status validateAnimationPageInput(const AnimationPageInput& in) {
  if (!(std::isfinite(in.robot_radius_m) && in.robot_radius_m > 0)) {
    return invalidArgument("animation page: robot radius " + num(in.robot_radius_m) + " m is not a positive number");
  }
  for (const auto& [what, v] : {std::pair<const char*, double>{"length", in.robot_length_m}, {"width", in.robot_width_m}})
    if (!(std::isfinite(v) && v >= 0 && v <= 1000.0))
      return invalidArgument(std::string("animation page: robot box ") + what + " " + num(v) +
                             " m is not a number from 0 (a disc) to 1000");
  for (std::size_t m = 0; m < in.movers.size(); ++m) {
    const PageMover& mv = in.movers[m];
    if (!(std::isfinite(mv.radius_m) && mv.radius_m > 0)) {
      return invalidArgument("animation page: mover " + std::to_string(m) + " ('" + mv.name + "') radius " +
                             num(mv.radius_m) + " m is not a positive number");
    }
    if (mv.colour > 0xFFFFFF) {
      return invalidArgument("animation page: mover " + std::to_string(m) + " ('" + mv.name +
                             "') colour is not 0xRRGGBB");
    }
  }
  if (in.frames.empty()) return invalidArgument("animation page: no frames (a run needs at least one)");
  for (std::size_t i = 0; i < in.frames.size(); ++i) {
    const PageFrame& f = in.frames[i];
    if (!std::isfinite(f.t_s) || std::abs(f.t_s) > kMaxTime_s) {
      return invalidArgument("animation page: frame " + std::to_string(i) + " time " + num(f.t_s) +
                             " s is not a finite time");
    }
    if (i > 0 && f.t_s < in.frames[i - 1].t_s) {
      return invalidArgument(frameName(in, i) + " comes after frame " + std::to_string(i - 1) + " (t = " +
                             num(in.frames[i - 1].t_s) + " s): frames must be in time order");
    }
    ADIT_RETURN_IF_ERROR(checkPoint(f.robot, frameName(in, i) + ": robot"));
    if (std::isinf(f.yaw) || std::abs(f.yaw) > 1e6)
      return invalidArgument(frameName(in, i) + ": robot yaw " + num(f.yaw) + " rad is not finite (NaN: not known)");
    if (f.movers.size() != in.movers.size()) {
      return invalidArgument(frameName(in, i) + " has " + std::to_string(f.movers.size()) +
                             " mover positions, expected " + std::to_string(in.movers.size()) +
                             " (one per mover)");
    }
    for (std::size_t m = 0; m < f.movers.size(); ++m) {
      ADIT_RETURN_IF_ERROR(checkPoint(f.movers[m], frameName(in, i) + ": mover " + std::to_string(m)));
    }
  }
  for (std::size_t k = 0; k < in.initial_path.size(); ++k)
    ADIT_RETURN_IF_ERROR(checkPoint(in.initial_path[k], "animation page: initial path point " + std::to_string(k)));
  auto checkTime = [](double t, double before, const std::string& what) -> Status {
    if (!std::isfinite(t) || std::abs(t) > kMaxTime_s)
      return invalidArgument(what + " time " + num(t) + " s is not a finite time");
    if (t < before) return invalidArgument(what + " at t = " + num(t) + " s comes after one at " + num(before) +
                                           " s: they must be in time order");
    return {};
  };
  double before = -kMaxTime_s;
  for (std::size_t k = 0; k < in.events.size(); ++k) {
    const PageEvent& e = in.events[k];
    const std::string what = "animation page: event " + std::to_string(k) + " (" + e.kind + ")";
    ADIT_RETURN_IF_ERROR(checkTime(e.t_s, before, what));
    before = e.t_s;
    if (!(std::isfinite(e.radius_m) && e.radius_m >= 0))
      return invalidArgument(what + " radius " + num(e.radius_m) + " m is not a number >= 0");
    if (e.radius_m > 0) ADIT_RETURN_IF_ERROR(checkPoint(e.center, what + ": centre"));
    for (std::size_t j = 0; j < e.path.size(); ++j)
      ADIT_RETURN_IF_ERROR(checkPoint(e.path[j], what + ": path point " + std::to_string(j)));
  }
  for (const auto* list : {&in.sensed, &in.subgoals}) {
    const std::string what = list == &in.sensed ? "animation page: sensed point " : "animation page: sub-goal ";
    before = -kMaxTime_s;
    for (std::size_t k = 0; k < list->size(); ++k) {
      ADIT_RETURN_IF_ERROR(checkTime((*list)[k].t_s, before, what + std::to_string(k)));
      before = (*list)[k].t_s;
      ADIT_RETURN_IF_ERROR(checkPoint((*list)[k].p, what + std::to_string(k)));
    }
  }
  return {};
}

StatusOr<std::string> animationPageHtml(const std::vector<unsigned char>& png, const TopViewInfo& view,
                                        const AnimationPageInput& in, AnimationPageInfo* info) {
  ADIT_RETURN_IF_ERROR(validateAnimationPageInput(in));
  ADIT_RETURN_IF_ERROR(checkView(png, view));
  try {
    std::vector<std::pair<std::string, std::uint32_t>> statuses;
    const std::string data =
        scriptSafe(frameData(view, in, &statuses).dump(-1, ' ', false, json::error_handler_t::replace));
    const std::string title = htmlEscape(in.title.empty() ? std::string("adit run") : in.title);
    const double duration_s = in.frames.back().t_s - in.frames.front().t_s;
    std::string html;
    html.reserve(data.size() + png.size() * 4 / 3 + 32768);
    html += "<!DOCTYPE html>\n<html lang=\"en\" data-errors=\"0\" data-frame=\"-1\" data-ready=\"0\" data-events=\"" + std::to_string(in.events.size()) + "\">\n<head>\n"
            "<meta charset=\"utf-8\">\n"
            "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; "
            "style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
            "<meta name=\"generator\" content=\"adit\">\n"
            "<link rel=\"icon\" href=\"data:,\">\n<title>" + title + " \xE2\x80\x94 adit</title>\n<style>";
    html += kStyle;
    html += "</style>\n<script>";
    html += kErrorScript;
    html += "</script>\n</head>\n<body>\n<header><h1>" + title + "</h1><span class=\"sub\">" +
            std::to_string(in.frames.size()) + " frames \xC2\xB7 " + fixed(duration_s, 1) + " s \xC2\xB7 " +
            std::to_string(in.movers.size()) + " moving obstacle" + (in.movers.size() == 1 ? "" : "s") +
            " \xC2\xB7 " + std::to_string(in.events.size()) + " event" + (in.events.size() == 1 ? "" : "s") +
            "</span></header>\n<main>\n";
    appendStage(html, png, view, in);
    html += "<aside>\n";
    appendClockAndRobot(html, in);
    appendLegend(html, in, statuses);
    appendEventList(html, in);
    if (!in.summary.empty()) {
      html += "<div class=\"panel\"><h2>Summary</h2><table>\n";
      appendSummaryRows(html, in);
      html += "</table></div>\n";
    }
    html += "<noscript><div class=\"panel\">The animation needs JavaScript; the picture and the summary do not."
            "</div></noscript>\n<pre id=\"errors\" hidden></pre>\n</aside>\n</main>\n"
            "<footer><kbd>space</kbd> play/pause \xC2\xB7 <kbd>\xE2\x86\x90</kbd> <kbd>\xE2\x86\x92</kbd> step \xC2\xB7 "
            "<kbd>Home</kbd> <kbd>End</kbd> \xC2\xB7 <code>#t=SECONDS</code> in the address opens paused at that time. "
            "Self-contained page written by adit; it loads nothing from the network.</footer>\n"
            "<script type=\"application/json\" id=\"adit-data\">";
    html += data;
    html += "</script>\n<script>";
    html += kMainScript;
    html += "</script>\n</body>\n</html>\n";

    if (info != nullptr) {
      info->page_bytes = html.size();
      info->background_bytes = png.size();
      info->frame_data_bytes = data.size();
      info->frames = in.frames.size();
      info->events = in.events.size();
    }
    return html;
  } catch (const std::exception& e) {
    return internalError(std::string("animation page: ") + e.what());
  }
}

Status writeAnimationPageHtml(const std::vector<unsigned char>& png, const TopViewInfo& view,
                              const AnimationPageInput& input, const std::string& path, AnimationPageInfo* info) {
  AnimationPageInfo written;
  ADIT_ASSIGN_OR_RETURN(const std::string html, animationPageHtml(png, view, input, &written));
  ADIT_RETURN_IF_ERROR(adit::map::writeFileAtomically(path, [&html](std::ostream& out) {
    out.write(html.data(), static_cast<std::streamsize>(html.size()));
    return static_cast<bool>(out);
  }));
  if (info != nullptr) *info = written;
  return {};
}

Status writeAnimationPage(const Figure& background, const AnimationPageInput& input, const std::string& path,
                          AnimationPageInfo* info) {
  // Refuse bad frames before paying for the picture.
  ADIT_RETURN_IF_ERROR(validateAnimationPageInput(input));
  std::vector<unsigned char> png;
  TopViewInfo view;
  ADIT_RETURN_IF_ERROR(background.renderPng(&png, &view));
  return writeAnimationPageHtml(png, view, input, path, info);
}

}  // namespace adit::tools
