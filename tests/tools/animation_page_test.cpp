// SPDX-License-Identifier: BSD-3-Clause
// The animated page: its text is checked as a file (one file, nothing fetched, frames encoded
// exactly, text escaped) and its frame data is decoded back and compared with the input. Whether
// the script runs is checked in a real browser by the `browser` tests (browser_page.cmake).
#include "common/animation_page.hpp"

#include <cairo.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <limits>
#include <string>
#include <vector>

#include "adit/map/map_io.hpp"

namespace adit::tools {
namespace {

namespace fs = std::filesystem;
using adit::StatusCode;
using adit::map::Vec3;
using nlohmann::json;

/// A plain PNG of the given size made with Cairo: the page only embeds it.
std::vector<unsigned char> plainPng(int width, int height) {
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height);
  cairo_t* cr = cairo_create(surface);
  cairo_set_source_rgb(cr, 0.13, 0.13, 0.15);
  cairo_paint(cr);
  cairo_destroy(cr);
  std::vector<unsigned char> png;
  cairo_surface_write_to_png_stream(
      surface,
      [](void* closure, const unsigned char* data, unsigned int length) {
        auto* out = static_cast<std::vector<unsigned char>*>(closure);
        out->insert(out->end(), data, data + length);
        return CAIRO_STATUS_SUCCESS;
      },
      &png);
  cairo_surface_destroy(surface);
  return png;
}

/// 20 m x 10 m of world at 10 px/m with a 30 px margin on the left and 20 px on top.
TopViewInfo plainView() {
  TopViewInfo v;
  v.width_px = 260;
  v.height_px = 140;
  v.pixels_per_m = 10.0;
  v.map_left_px = 30;
  v.map_top_px = 20;
  v.map_width_px = 200;
  v.map_height_px = 100;
  v.x_min_m = -2.0;
  v.y_max_m = 8.0;
  return v;
}

/// A robot crossing the area diagonally with `movers` obstacles on their own lines; the status
/// changes from following to yielding to arrived so the status runs have several entries.
AnimationPageInput sampleRun(std::size_t frames, std::size_t movers, double dt = 0.1) {
  AnimationPageInput in;
  in.title = "sample run";
  in.robot_radius_m = 0.3;
  for (std::size_t m = 0; m < movers; ++m) {
    in.movers.push_back({"obstacle " + std::to_string(m + 1), 0.25 + 0.05 * static_cast<double>(m % 3), kFigureMoving});
  }
  for (std::size_t i = 0; i < frames; ++i) {
    const double t = dt * static_cast<double>(i);
    const double s = frames > 1 ? static_cast<double>(i) / static_cast<double>(frames - 1) : 0.0;
    PageFrame f;
    f.t_s = t;
    f.robot = Vec3(-1.0 + 18.0 * s + 0.3 * std::sin(t), 7.0 - 8.0 * s, 0.5 + 0.2 * s);
    f.status = i + 1 == frames ? "arrived" : (i % 50 < 40 ? "following" : "yielding");
    for (std::size_t m = 0; m < movers; ++m) {
      const double phase = static_cast<double>(m);
      f.movers.push_back(Vec3(16.0 - 0.25 * t + 0.5 * std::cos(t + phase), 6.0 - 0.6 * phase + 0.01 * t * t, 0.0));
    }
    in.frames.push_back(std::move(f));
  }
  in.summary = {{"outcome", "arrived"}, {"arrival time", "12.3 s"}};
  return in;
}

std::string between(const std::string& s, const std::string& open, const std::string& close) {
  const auto a = s.find(open);
  if (a == std::string::npos) return {};
  const auto b = s.find(close, a + open.size());
  if (b == std::string::npos) return {};
  return s.substr(a + open.size(), b - a - open.size());
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto p = s.find(what); p != std::string::npos; p = s.find(what, p + 1)) ++n;
  return n;
}

/// The page's frame data, decoded the way its script does (cumulative sums of integers).
json frameData(const std::string& html) {
  return json::parse(between(html, "<script type=\"application/json\" id=\"adit-data\">", "</script>"));
}
std::vector<double> undelta(const json& a, double scale) {
  std::vector<double> out;
  long long acc = 0;
  for (const auto& v : a) {
    acc += v.get<long long>();
    out.push_back(static_cast<double>(acc) / scale);
  }
  return out;
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

class AnimationPageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("adit_animation_page_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::vector<fs::path> files() const {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir_)) out.push_back(e.path().filename());
    return out;
  }

  /// Writes `in` to a fresh path; on failure asserts that nothing at all was left in the folder.
  Status writeExpectingNothingOnError(const AnimationPageInput& in) {
    const fs::path page = dir_ / "page.html";
    Status s = writeAnimationPageHtml(png_, view_, in, page.string());
    if (!s.ok()) {
      EXPECT_TRUE(files().empty()) << "a failed write left a file behind";
    }
    return s;
  }

  fs::path dir_;
  std::vector<unsigned char> png_ = plainPng(260, 140);
  TopViewInfo view_ = plainView();
};

TEST_F(AnimationPageTest, OneSelfContainedFileThatFetchesNothing) {
  const fs::path page = dir_ / "run.html";
  AnimationPageInfo info;
  ASSERT_TRUE(writeAnimationPageHtml(png_, view_, sampleRun(120, 3), page.string(), &info).ok());
  EXPECT_EQ(files(), std::vector<fs::path>{"run.html"});
  const std::string html = readAll(page);
  EXPECT_EQ(info.page_bytes, html.size());
  EXPECT_EQ(info.background_bytes, png_.size());
  EXPECT_EQ(info.frames, 120u);

  for (const char* remote : {"http://", "https://", "//cdn", "ftp://", "ws://", "@import", "url("}) {
    EXPECT_EQ(html.find(remote), std::string::npos) << remote;
  }
  // The only src is the picture, inline; the only link is the empty inline icon; scripts are inline.
  EXPECT_EQ(count(html, "src=\""), 1u);
  EXPECT_NE(html.find("src=\"data:image/png;base64,iVBORw0KGgo"), std::string::npos);
  EXPECT_EQ(count(html, "<link"), 1u);
  EXPECT_NE(html.find("<link rel=\"icon\" href=\"data:,\">"), std::string::npos);
  EXPECT_EQ(html.find("<script src"), std::string::npos);
  // The browser itself refuses any fetch the page might attempt.
  EXPECT_NE(html.find("content=\"default-src 'none'; img-src data:;"), std::string::npos);
  // Controls and panels the page promises.
  for (const char* id : {"id=\"play\"", "id=\"slider\"", "id=\"speed\"", "id=\"clock\"", "id=\"status\"",
                         "id=\"errors\"", "max=\"119\""}) {
    EXPECT_NE(html.find(id), std::string::npos) << id;
  }
  EXPECT_NE(html.find("<td>outcome</td><td>arrived</td>"), std::string::npos);
}

TEST_F(AnimationPageTest, EmbedsTheBackgroundBytesExactly) {
  const auto html = animationPageHtml(png_, view_, sampleRun(3, 0));
  ASSERT_TRUE(html.ok()) << html.status().toString();
  const std::string b64 = between(*html, "data:image/png;base64,", "\"");
  // Decode with the alphabet's inverse and compare: the page must show the renderer's picture.
  std::vector<unsigned char> decoded;
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::uint32_t acc = 0;
  int bits = 0;
  for (char c : b64) {
    if (c == '=') break;
    const auto k = alphabet.find(c);
    ASSERT_NE(k, std::string::npos) << "not base64: " << c;
    acc = (acc << 6) | static_cast<std::uint32_t>(k);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      decoded.push_back(static_cast<unsigned char>((acc >> bits) & 0xFF));
    }
  }
  EXPECT_EQ(b64.size() % 4, 0u);
  EXPECT_EQ(decoded, png_);
}

TEST_F(AnimationPageTest, FramesAreAllThereInOrderToTheMillimetre) {
  const AnimationPageInput in = sampleRun(250, 4);
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok()) << html.status().toString();
  const json d = frameData(*html);

  const auto t = undelta(d["t"], 1000), x = undelta(d["robot"]["x"], 1000), y = undelta(d["robot"]["y"], 1000),
             z = undelta(d["robot"]["z"], 1000);
  ASSERT_EQ(t.size(), in.frames.size());
  ASSERT_EQ(x.size(), in.frames.size());
  ASSERT_EQ(d["movers"].size(), 4u);
  std::vector<std::vector<double>> mx, my;
  for (const auto& m : d["movers"]) {
    mx.push_back(undelta(m["x"], 1000));
    my.push_back(undelta(m["y"], 1000));
    ASSERT_EQ(mx.back().size(), in.frames.size());
  }
  for (std::size_t i = 0; i < in.frames.size(); ++i) {
    const PageFrame& f = in.frames[i];
    if (i > 0) {
      EXPECT_GT(t[i], t[i - 1]) << "frame " << i;
    }
    EXPECT_NEAR(t[i], f.t_s, 0.0005 + 1e-12) << "frame " << i;
    EXPECT_NEAR(x[i], f.robot.x(), 0.0005 + 1e-12) << "frame " << i;
    EXPECT_NEAR(y[i], f.robot.y(), 0.0005 + 1e-12) << "frame " << i;
    EXPECT_NEAR(z[i], f.robot.z(), 0.0005 + 1e-12) << "frame " << i;
    for (std::size_t m = 0; m < 4; ++m) {
      EXPECT_NEAR(mx[m][i], f.movers[m].x(), 0.0005 + 1e-12) << "frame " << i << " mover " << m;
      EXPECT_NEAR(my[m][i], f.movers[m].y(), 0.0005 + 1e-12) << "frame " << i << " mover " << m;
    }
  }
  EXPECT_DOUBLE_EQ(d["robot"]["r"].get<double>(), 0.3);
  EXPECT_DOUBLE_EQ(d["movers"][1]["r"].get<double>(), in.movers[1].radius_m);
  EXPECT_EQ(d["movers"][0]["c"], "#9B59B6");
  // The world-to-picture mapping is the renderer's, number for number.
  EXPECT_EQ(d["view"]["w"], 260);
  EXPECT_EQ(d["view"]["left"], 30);
  EXPECT_EQ(d["view"]["top"], 20);
  EXPECT_DOUBLE_EQ(d["view"]["ppm"].get<double>(), 10.0);
  EXPECT_DOUBLE_EQ(d["view"]["xmin"].get<double>(), -2.0);
  EXPECT_DOUBLE_EQ(d["view"]["ymax"].get<double>(), 8.0);
}

// A ground robot's box footprint travels with its heading per frame, unwrapped so that a turn
// through +-pi interpolates the short way; a disc robot's page carries neither.
TEST_F(AnimationPageTest, ABoxRobotCarriesItsFootprintAndHeading) {
  AnimationPageInput in = sampleRun(40, 0);
  ASSERT_FALSE(frameData(*animationPageHtml(png_, view_, in)).at("robot").contains("box"));
  in.robot_length_m = 1.0;
  in.robot_width_m = 0.7;
  for (std::size_t i = 0; i < in.frames.size(); ++i) in.frames[i].yaw = std::remainder(2.9 + 0.05 * double(i), 6.283185307179586);
  in.frames[3].yaw = std::numeric_limits<double>::quiet_NaN();  // not known: the last one held
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok()) << html.status().toString();
  const json d = frameData(*html);
  EXPECT_EQ(d["robot"]["box"], json::array({1.0, 0.7}));
  const auto yaw = undelta(d["robot"]["yaw"], 1000);
  ASSERT_EQ(yaw.size(), in.frames.size());
  for (std::size_t i = 1; i < yaw.size(); ++i) {
    const double want = i == 3 ? 2.9 + 0.05 * 2 : 2.9 + 0.05 * double(i);
    EXPECT_NEAR(yaw[i], want, 0.0015) << "frame " << i;
  }
  EXPECT_NE(html->find("1.00 &times; 0.70 m"), std::string::npos) << "the legend names the box";
  // Bad footprints and headings are refused.
  AnimationPageInput bad = in;
  bad.robot_width_m = -0.7;
  EXPECT_FALSE(validateAnimationPageInput(bad).ok());
  bad = in;
  bad.robot_length_m = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(validateAnimationPageInput(bad).ok());
  bad = in;
  bad.frames[5].yaw = -std::numeric_limits<double>::infinity();
  const Status s = validateAnimationPageInput(bad);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("yaw"), std::string::npos) << s.message();
}

TEST_F(AnimationPageTest, StatusPerFrameIsStoredAsRuns) {
  const AnimationPageInput in = sampleRun(101, 1);
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok());
  const json d = frameData(*html);
  const json& names = d["status"]["names"];
  const json& runs = d["status"]["runs"];
  ASSERT_EQ(names, json({"following", "yielding", "arrived"}));
  // Expand the runs as the page does and compare frame by frame.
  std::vector<std::string> per_frame(in.frames.size());
  for (std::size_t k = 0; k < runs.size(); k += 2) {
    const std::size_t from = runs[k].get<std::size_t>();
    const std::size_t to = k + 2 < runs.size() ? runs[k + 2].get<std::size_t>() : in.frames.size();
    for (std::size_t i = from; i < to; ++i) per_frame[i] = names[runs[k + 1].get<std::size_t>()];
  }
  for (std::size_t i = 0; i < in.frames.size(); ++i) EXPECT_EQ(per_frame[i], in.frames[i].status) << i;
  EXPECT_EQ(runs.size(), 2u * 5u);  // following, yielding, following, yielding, arrived
  EXPECT_EQ(d["status"]["colours"].size(), names.size());
}

TEST_F(AnimationPageTest, HostileTextIsEscapedEverywhere) {
  AnimationPageInput in = sampleRun(5, 1);
  const std::string evil = "</script><script>alert(1)</script><img src=x onerror=alert(2)> & \"q\" 'a'";
  in.title = evil;
  in.movers[0].name = evil;
  in.summary = {{evil, evil}};
  in.frames[2].status = evil;
  in.events = {{0.2, evil, evil, evil, Vec3::Zero(), 0.0, {}}};
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok()) << html.status().toString();
  EXPECT_EQ(html->find("alert(1)</script>"), std::string::npos);
  EXPECT_EQ(html->find("<img src=x"), std::string::npos);
  EXPECT_EQ(count(*html, "<script"), 3u);  // the error recorder, the data, the player
  EXPECT_EQ(count(*html, "</script"), 3u);
  EXPECT_NE(html->find("<h1>&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;&lt;img src=x onerror=alert(2)&gt; "
                       "&amp; &quot;q&quot; &#39;a&#39;</h1>"),
            std::string::npos);
  // The status travels in the JSON block, escaped for a script element, and decodes unchanged.
  EXPECT_EQ(frameData(*html)["status"]["names"][1], evil);
  EXPECT_EQ(frameData(*html)["events"][0]["kind"], evil);
}

/// sampleRun with a replay's layers: a roof fall at 2 s, a replan between two frames (3.05 s,
/// so its frame is the one at 3.1 s) with its path, sensed rock and sub-goals, the arrival.
AnimationPageInput replayRun() {
  AnimationPageInput in = sampleRun(100, 2);
  in.initial_path = {Vec3(-1, 7, 0), Vec3(17, -1, 0)};
  in.events.push_back({2.0, "roof_fall", "ball of r = 1.5 m", "", Vec3(8.25, 3.5, 0), 1.5, {}});
  in.events.push_back({3.05, "replan", "expected path blocked", "replanning", Vec3::Zero(), 0.0,
                       {Vec3(4, 4, 0), Vec3(8, 6.5, 0), Vec3(17, -1, 0)}});
  in.events.push_back({9.9, "arrived", "at the goal", "", Vec3::Zero(), 0.0, {}});
  for (int k = 0; k < 5; ++k) in.sensed.push_back({2.5 + 0.1 * k, Vec3(7.0 + 0.3 * k, 4.9, 0)});
  in.subgoals = {{0.0, Vec3(1, 5, 0)}, {1.0, Vec3(3, 4, 0)}, {4.0, Vec3(9, 5.5, 0)}};
  return in;
}

TEST_F(AnimationPageTest, EventsTravelWithTheirTimesFramesAndMarks) {
  const AnimationPageInput in = replayRun();
  AnimationPageInfo info;
  const auto html = animationPageHtml(png_, view_, in, &info);
  ASSERT_TRUE(html.ok()) << html.status().toString();
  EXPECT_EQ(info.events, 3u);
  const json d = frameData(*html);
  ASSERT_EQ(d["events"].size(), 3u);
  EXPECT_EQ(d["events"][0]["kind"], "roof_fall");
  EXPECT_EQ(d["events"][0]["t"], 2000);
  EXPECT_EQ(d["events"][0]["f"], 20);
  EXPECT_EQ(d["events"][0]["disc"], json({{"x", 8250}, {"y", 3500}, {"r", 1500}}));
  EXPECT_EQ(d["events"][1]["kind"], "replan");
  EXPECT_EQ(d["events"][1]["t"], 3050);
  EXPECT_EQ(d["events"][1]["f"], 31);  // the first frame at or after the event
  EXPECT_EQ(undelta(d["events"][1]["path"]["x"], 1000), std::vector<double>({4, 8, 17}));
  EXPECT_EQ(undelta(d["events"][1]["path"]["y"], 1000), std::vector<double>({4, 6.5, -1}));
  EXPECT_FALSE(d["events"][1].contains("disc"));
  EXPECT_EQ(d["events"][2]["f"], 99);
  EXPECT_EQ(undelta(d["initial_path"]["x"], 1000), std::vector<double>({-1, 17}));
  EXPECT_EQ(undelta(d["sensed"]["t"], 1), std::vector<double>({2500, 2600, 2700, 2800, 2900}));
  EXPECT_EQ(undelta(d["subgoals"]["t"], 1), std::vector<double>({0, 1000, 4000}));
  EXPECT_EQ(undelta(d["subgoals"]["x"], 1000), std::vector<double>({1, 3, 9}));

  // One clickable mark per event, with its time and frame, and the same in the event list.
  EXPECT_NE(html->find("data-events=\"3\">\n<head>"), std::string::npos);
  EXPECT_NE(html->find("<div id=\"marks\" class=\"marks\" data-events=\"3\">"), std::string::npos);
  EXPECT_EQ(count(*html, "class=\"mark\""), 3u);
  EXPECT_NE(html->find("data-event=\"1\" data-kind=\"replan\" data-t=\"3.050\" data-frame=\"31\" style=\"left:30.808%"),
            std::string::npos);
  EXPECT_EQ(count(*html, "class=\"ev\""), 3u);
  EXPECT_NE(html->find("t = 3.0 s \xC2\xB7 replan: expected path blocked"), std::string::npos);
  EXPECT_NE(html->find("2 moving obstacles \xC2\xB7 3 events</span>"), std::string::npos);
  for (const char* legend : {"expected path in force", "expected path replaced by a replan", "roof fall (from its time)",
                             "rock the sensor saw", "sub-goals chosen so far"})
    EXPECT_NE(html->find(legend), std::string::npos) << legend;
}

TEST_F(AnimationPageTest, TheReplansFrameSaysReplanning) {
  const auto html = animationPageHtml(png_, view_, replayRun());
  ASSERT_TRUE(html.ok());
  const json d = frameData(*html);
  const json& names = d["status"]["names"];
  const json& runs = d["status"]["runs"];
  auto statusOf = [&](std::size_t frame) {
    std::string name;
    for (std::size_t k = 0; k < runs.size(); k += 2)
      if (runs[k].get<std::size_t>() <= frame) name = names[runs[k + 1].get<std::size_t>()];
    return name;
  };
  EXPECT_EQ(statusOf(30), "following");
  EXPECT_EQ(statusOf(31), "replanning");
  EXPECT_EQ(statusOf(32), "following");
  EXPECT_NE(html->find(">replanning</span>"), std::string::npos);  // its badge in the legend
}

TEST_F(AnimationPageTest, MoversAreTaggedByTheirNames) {
  AnimationPageInput in = sampleRun(10, 3);
  in.movers[0].name = "obstacle 1";
  in.movers[1].name = "obstacle 4";
  in.movers[2].name = "obstacle 5";
  auto tags = [this](const AnimationPageInput& run) {
    std::vector<std::string> out;
    const auto html = animationPageHtml(png_, view_, run);
    EXPECT_TRUE(html.ok());
    const json d = frameData(*html);
    for (const auto& m : d["movers"]) out.push_back(m["tag"]);
    return out;
  };
  EXPECT_EQ(tags(in), std::vector<std::string>({"1", "4", "5"}));
  const auto html = animationPageHtml(png_, view_, in);
  EXPECT_NE(html->find(">4</span>obstacle 4, r = "), std::string::npos);  // the legend agrees
  EXPECT_NE(html->find("3 moving obstacles"), std::string::npos);
  in.movers[0].name = "a";
  in.movers[1].name = "b";
  in.movers[2].name = "machine";
  EXPECT_EQ(tags(in), std::vector<std::string>({"a", "b", "3"}));
  in.movers[0].name = "cart 2";  // two would read "2": all by their places instead
  in.movers[1].name = "truck 2";
  EXPECT_EQ(tags(in), std::vector<std::string>({"1", "2", "3"}));
}

TEST_F(AnimationPageTest, BadEventsAndTimedPointsAreRefused) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    const char* what;
    std::function<void(AnimationPageInput&)> spoil;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"event time", [nan](AnimationPageInput& in) { in.events[1].t_s = nan; }, "event 1 (replan) time nan s"},
      {"event order", [](AnimationPageInput& in) { in.events[2].t_s = 1.0; },
       "event 2 (arrived) at t = 1 s comes after one at 3.05 s"},
      {"event radius", [](AnimationPageInput& in) { in.events[0].radius_m = -1; }, "event 0 (roof_fall) radius -1 m"},
      {"event path", [nan](AnimationPageInput& in) { in.events[1].path[1].y() = nan; },
       "event 1 (replan): path point 1 y is nan"},
      {"sensed order", [](AnimationPageInput& in) { in.sensed[3].t_s = 0.5; }, "sensed point 3 at t = 0.5 s"},
      {"sub-goal", [](AnimationPageInput& in) { in.subgoals[1].p.x() = INFINITY; }, "sub-goal 1 x is inf"},
      {"initial path", [nan](AnimationPageInput& in) { in.initial_path[0].x() = nan; }, "initial path point 0 x"},
  };
  for (const Case& c : cases) {
    AnimationPageInput in = replayRun();
    c.spoil(in);
    const Status s = writeExpectingNothingOnError(in);
    EXPECT_FALSE(s.ok()) << c.what;
    EXPECT_NE(s.message().find(c.message), std::string::npos) << c.what << ": " << s.message();
  }
}

// Text from a scenario file may be any bytes; a broken UTF-8 sequence must not fail the page.
TEST_F(AnimationPageTest, InvalidUtf8IsReplacedNotFatal) {
  AnimationPageInput in = sampleRun(4, 1);
  in.frames[1].status = "stuck\xff\xfe";
  in.movers[0].name = "cart \xc3";
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok()) << html.status().toString();
  EXPECT_EQ(frameData(*html)["status"]["names"][1], "stuck\xEF\xBF\xBD\xEF\xBF\xBD");  // U+FFFD twice
}

TEST_F(AnimationPageTest, BadInputIsRefusedAndLeavesNoFile) {
  struct Case {
    const char* what;
    std::function<void(AnimationPageInput&)> spoil;
    const char* message;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"empty", [](AnimationPageInput& in) { in.frames.clear(); }, "no frames"},
      {"NaN robot", [nan](AnimationPageInput& in) { in.frames[7].robot.y() = nan; },
       "frame 7 (t = 0.7 s): robot y is nan"},
      {"infinite mover", [](AnimationPageInput& in) { in.frames[3].movers[1].x() = -INFINITY; },
       "frame 3 (t = 0.3 s): mover 1 x is -inf"},
      {"NaN time", [nan](AnimationPageInput& in) { in.frames[4].t_s = nan; }, "frame 4 time nan s"},
      {"time goes back", [](AnimationPageInput& in) { in.frames[6].t_s = 0.2; },
       "frame 6 (t = 0.2 s) comes after frame 5 (t = 0.5 s): frames must be in time order"},
      {"mover count", [](AnimationPageInput& in) { in.frames[9].movers.pop_back(); },
       "frame 9 (t = 0.9 s) has 1 mover positions, expected 2"},
      {"robot radius", [](AnimationPageInput& in) { in.robot_radius_m = 0.0; }, "robot radius 0 m"},
      {"mover radius", [nan](AnimationPageInput& in) { in.movers[1].radius_m = nan; },
       "mover 1 ('obstacle 2') radius nan m"},
      {"far away", [](AnimationPageInput& in) { in.frames[2].robot.x() = 5e7; }, "robot x = 5e+07 m is beyond"},
  };
  for (const Case& c : cases) {
    AnimationPageInput in = sampleRun(12, 2);
    c.spoil(in);
    const Status s = writeExpectingNothingOnError(in);
    EXPECT_FALSE(s.ok()) << c.what;
    EXPECT_NE(s.message().find(c.message), std::string::npos) << c.what << ": " << s.message();
    EXPECT_EQ(validateAnimationPageInput(in).message(), s.message()) << c.what;
  }
}

TEST_F(AnimationPageTest, BadBackgroundIsRefusedAndLeavesNoFile) {
  const AnimationPageInput in = sampleRun(4, 0);
  const fs::path page = dir_ / "page.html";
  Status s = writeAnimationPageHtml({}, view_, in, page.string());
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("not a PNG (0 bytes)"), std::string::npos) << s.message();
  std::vector<unsigned char> jpeg = {0xFF, 0xD8, 0xFF, 0xE0, 0, 0x10, 'J', 'F', 'I', 'F'};
  EXPECT_FALSE(writeAnimationPageHtml(jpeg, view_, in, page.string()).ok());
  TopViewInfo v = view_;
  v.pixels_per_m = 0;
  s = writeAnimationPageHtml(png_, v, in, page.string());
  EXPECT_NE(s.message().find("scale 0 px/m"), std::string::npos) << s.message();
  v = view_;
  v.height_px = 0;
  EXPECT_FALSE(writeAnimationPageHtml(png_, v, in, page.string()).ok());
  EXPECT_TRUE(files().empty());
}

TEST_F(AnimationPageTest, FailedWriteKeepsThePreviousPage) {
  const fs::path page = dir_ / "page.html";
  ASSERT_TRUE(writeAnimationPageHtml(png_, view_, sampleRun(10, 1), page.string()).ok());
  const std::string before = readAll(page);
  AnimationPageInput bad = sampleRun(10, 1);
  bad.frames[5].robot.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(writeAnimationPageHtml(png_, view_, bad, page.string()).ok());
  EXPECT_EQ(readAll(page), before);
  EXPECT_EQ(files(), std::vector<fs::path>{"page.html"});

  const Status s = writeAnimationPageHtml(png_, view_, sampleRun(10, 1), (dir_ / "no" / "page.html").string());
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_NE(s.message().find("does not exist"), std::string::npos) << s.message();
}

TEST_F(AnimationPageTest, SingleFrameAndEqualTimesAreFine) {
  EXPECT_TRUE(animationPageHtml(png_, view_, sampleRun(1, 2)).ok());
  AnimationPageInput in = sampleRun(5, 0);
  in.frames[3].t_s = in.frames[2].t_s;  // a collision reported at the same instant as the step
  EXPECT_TRUE(animationPageHtml(png_, view_, in).ok());
  in.title.clear();
  in.summary.clear();
  const auto html = animationPageHtml(png_, view_, in);
  ASSERT_TRUE(html.ok());
  EXPECT_NE(html->find("<h1>adit run</h1>"), std::string::npos);
  EXPECT_EQ(html->find("<h2>Summary</h2>"), std::string::npos);
}

// 3000 frames (5 min at 0.1 s) with 10 moving obstacles: the frame data must stay a few hundred
// kB, not the megabytes that a JSON object per frame would take.
TEST_F(AnimationPageTest, LongRunStaysSmall) {
  const AnimationPageInput in = sampleRun(3000, 10);
  AnimationPageInfo info;
  const auto html = animationPageHtml(png_, view_, in, &info);
  ASSERT_TRUE(html.ok());
  const std::size_t numbers = 3000 * (4 + 2 * 10);
  std::cout << "[ page     ] 3000 frames x 10 movers: frame data " << info.frame_data_bytes << " bytes ("
            << static_cast<double>(info.frame_data_bytes) / static_cast<double>(numbers)
            << " bytes per number), page " << info.page_bytes << " bytes with a " << info.background_bytes
            << "-byte picture\n";
  EXPECT_LT(info.frame_data_bytes, numbers * 5);  // under 5 characters per number, separator included
  EXPECT_LT(info.page_bytes - info.frame_data_bytes, 40000 + info.background_bytes * 4 / 3);
}

TEST_F(AnimationPageTest, WritesTheFiguresPicture) {
  Figure fig;
  fig.setWorldBounds({Vec3(-2, -4, 0), Vec3(18, 8, 1)});
  fig.addLine({{Vec3(-1, 7, 0), Vec3(8, 3, 0), Vec3(17, -1, 0)}, kFigurePath, 2.0, true, {}, "expected path", ""});
  std::vector<unsigned char> png;
  TopViewInfo view;
  ASSERT_TRUE(fig.renderPng(&png, &view).ok());

  const fs::path page = dir_ / "fig.html";
  AnimationPageInfo info;
  ASSERT_TRUE(writeAnimationPage(fig, sampleRun(40, 2), page.string(), &info).ok());
  const std::string html = readAll(page);
  EXPECT_EQ(info.background_bytes, png.size());
  const json d = frameData(html);
  EXPECT_EQ(d["view"]["w"], view.width_px);
  EXPECT_EQ(d["view"]["h"], view.height_px);
  EXPECT_EQ(d["view"]["left"], view.map_left_px);
  EXPECT_EQ(d["view"]["top"], view.map_top_px);
  EXPECT_DOUBLE_EQ(d["view"]["ppm"].get<double>(), view.pixels_per_m);
  EXPECT_DOUBLE_EQ(d["view"]["xmin"].get<double>(), view.x_min_m);
  EXPECT_DOUBLE_EQ(d["view"]["ymax"].get<double>(), view.y_max_m);

  // Bad frames are refused before the picture is drawn; a figure with nothing to draw is the
  // renderer's error. Neither leaves a file.
  AnimationPageInput bad = sampleRun(40, 2);
  bad.frames.clear();
  EXPECT_FALSE(writeAnimationPage(fig, bad, (dir_ / "bad.html").string()).ok());
  const Status s = writeAnimationPage(Figure(), sampleRun(4, 0), (dir_ / "empty.html").string());
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(files(), std::vector<fs::path>{"fig.html"});
}

}  // namespace
}  // namespace adit::tools
