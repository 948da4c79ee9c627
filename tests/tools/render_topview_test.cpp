// SPDX-License-Identifier: BSD-3-Clause
// renderTopView: pictures are read back with Cairo and checked pixel by pixel at known places of
// generated roadways (junctionNetwork: main roadway y in [-2, 2] from x = 0 to 14 with floor 0 to
// 0.3 m, branch x in [12.5, 15.5] up to y = 10 with floor up to 0.5 m, cross-cut x in [4.5, 7.5]
// down to y = -8 with floor 0; rock elsewhere).
#include "common/figure.hpp"
#include "common/render_topview.hpp"

#include <cairo.h>
#include <octomap/OcTree.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "adit/map/survey_network.hpp"
#include "support/synthetic_roadway.hpp"

namespace adit::tools {
namespace {

namespace fs = std::filesystem;
using adit::StatusCode;

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;

/// A PNG read back with Cairo; colours as 0xRRGGBB.
class Picture {
 public:
  explicit Picture(const fs::path& path) : surface_(cairo_image_surface_create_from_png(path.c_str())) {}
  bool ok() const { return cairo_surface_status(surface_.get()) == CAIRO_STATUS_SUCCESS; }
  int width() const { return cairo_image_surface_get_width(surface_.get()); }
  int height() const { return cairo_image_surface_get_height(surface_.get()); }
  std::uint32_t at(int col, int row) const {
    const unsigned char* data = cairo_image_surface_get_data(surface_.get());
    const int stride = cairo_image_surface_get_stride(surface_.get());
    return *reinterpret_cast<const std::uint32_t*>(data + row * stride + 4 * col) & 0xFFFFFF;
  }
  /// Colour of the pixel holding world point (x, y).
  std::uint32_t atWorld(const TopViewInfo& info, double x, double y) const {
    return at(static_cast<int>(std::floor(info.columnOf(x))), static_cast<int>(std::floor(info.rowOf(y))));
  }

 private:
  SurfacePtr surface_;
};

class RenderTopViewTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("adit_render_topview_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_, fs::perms::owner_all, ec);
    fs::remove_all(dir_, ec);
  }
  static const map::OccupancyMap& junction() {
    static const map::OccupancyMap m = test::voxelizeOrFail(test::junctionNetwork(0.25));
    return m;
  }
  fs::path dir_;
};

TEST_F(RenderTopViewTest, ProjectionPngShowsRoadwaysOverRockBackground) {
  TopViewOptions o;
  o.title = "junction";
  o.max_pixels = 600;
  TopViewInfo info;
  const fs::path out = dir_ / "top.png";
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &info).ok());

  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_EQ(pic.width(), info.width_px);
  EXPECT_EQ(pic.height(), info.height_px);
  // The map (17.5 x 19.5 m) fills about max_pixels on its longer side; annotations add margins.
  EXPECT_NEAR(std::max(info.map_width_px, info.map_height_px), 600, 2);
  EXPECT_FALSE(info.scale_raised);
  EXPECT_GT(pic.width(), info.map_width_px + 100);
  EXPECT_LT(pic.width(), info.map_width_px + 700);
  EXPECT_GT(pic.height(), info.map_height_px + 80);
  EXPECT_LT(pic.height(), info.map_height_px + 400);
  EXPECT_GE(info.map_left_px, 1);
  EXPECT_LE(info.map_left_px + info.map_width_px, pic.width());
  EXPECT_LE(info.map_top_px + info.map_height_px, pic.height());

  // Roadway centres are drawn, each in a ramp colour (neither background nor page white).
  for (auto [x, y] : {std::pair{2.0, 0.0}, {10.0, 0.0}, {6.0, -5.0}, {14.0, 7.0}}) {
    SCOPED_TRACE(::testing::Message() << "roadway centre (" << x << ", " << y << ")");
    EXPECT_NE(pic.atWorld(info, x, y), kTopViewBackground);
    EXPECT_NE(pic.atWorld(info, x, y), 0xFFFFFFu);
  }
  // Rock between the roadways is background.
  for (auto [x, y] : {std::pair{3.0, 8.0}, {10.0, -6.0}, {2.0, -5.0}, {9.0, 6.0}}) {
    SCOPED_TRACE(::testing::Message() << "rock (" << x << ", " << y << ")");
    EXPECT_EQ(pic.atWorld(info, x, y), kTopViewBackground);
  }
  // Floor elevation colours: the cross-cut (floor 0) and the far branch (floor 0.5) differ.
  EXPECT_NE(pic.atWorld(info, 6.0, -5.0), pic.atWorld(info, 14.0, 8.0));
  ASSERT_TRUE(info.floor_min_m && info.floor_max_m);
  EXPECT_NEAR(*info.floor_min_m, 0.0, 0.25 + 1e-9);
  EXPECT_NEAR(*info.floor_max_m, 0.5, 0.25 + 1e-9);
  EXPECT_GT(info.free_pixels, 0u);
  EXPECT_GT(info.scale_bar_m, 0.0);
}

TEST_F(RenderTopViewTest, ProjectionColoursAColumnByItsLowestFloor) {
  // Two roadways crossing 10 m apart in height: at the crossing the lower floor wins.
  map::SurveyNetwork net;
  net.name = "crossing";
  net.resolution_m = 0.25;
  net.stations = {{"A", map::Vec3(0, 0, 0)}, {"B", map::Vec3(40, 0, 0)},
                  {"C", map::Vec3(20, -20, 10)}, {"D", map::Vec3(20, 20, 10)}};
  net.sections = {{"s", map::CrossSection::rectangle(4.0, 3.0)}};
  net.roadways = {{"low", {"A", "B"}, "s"}, {"high", {"C", "D"}, "s"}};
  const map::OccupancyMap m = test::voxelizeOrFail(net);

  TopViewOptions o;
  o.max_pixels = 400;
  TopViewInfo info;
  const fs::path out = dir_ / "crossing.png";
  ASSERT_TRUE(renderTopView(m, o, out.string(), &info).ok());
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  const std::uint32_t low = pic.atWorld(info, 10, 0), high = pic.atWorld(info, 20, 12);
  EXPECT_NE(low, kTopViewBackground);
  EXPECT_NE(high, kTopViewBackground);
  EXPECT_NE(low, high);
  EXPECT_EQ(pic.atWorld(info, 20, 0), low);
  ASSERT_TRUE(info.floor_min_m && info.floor_max_m);
  EXPECT_NEAR(*info.floor_max_m - *info.floor_min_m, 10.0, 0.5);
}

TEST_F(RenderTopViewTest, SliceShowsFreeOccupiedAndUnknown) {
  TopViewOptions o;
  o.max_pixels = 500;
  o.slice_z_m = 1.0;
  TopViewInfo info;
  const fs::path out = dir_ / "slice.png";
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &info).ok());
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_EQ(pic.atWorld(info, 10, 0), kTopViewSliceFree);
  EXPECT_EQ(pic.atWorld(info, 6, -5), kTopViewSliceFree);
  EXPECT_EQ(pic.atWorld(info, 10, 2.3), kTopViewSliceOccupied);  // the rock shell beside the wall
  EXPECT_EQ(pic.atWorld(info, 3, 8), kTopViewBackground);        // never surveyed
  EXPECT_GT(info.free_pixels, 0u);
  EXPECT_FALSE(info.floor_min_m.has_value());
}

TEST_F(RenderTopViewTest, SliceAboveTheRoofShowsNoFreeSpace) {
  // The highest roof is 0.3 + 4.5 m (main arch at B); the rock shell reaches 5.5 m.
  TopViewOptions o;
  o.max_pixels = 400;
  o.slice_z_m = 5.2;
  o.slice_band_m = 0.2;
  TopViewInfo info;
  const fs::path out = dir_ / "above.png";
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &info).ok());
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_EQ(info.free_pixels, 0u);
  int free = 0, occupied = 0;
  for (int r = info.map_top_px; r < info.map_top_px + info.map_height_px; ++r)
    for (int c = info.map_left_px; c < info.map_left_px + info.map_width_px; ++c) {
      free += pic.at(c, r) == kTopViewSliceFree;
      occupied += pic.at(c, r) == kTopViewSliceOccupied;
    }
  EXPECT_EQ(free, 0);
  EXPECT_GT(occupied, 0);  // the shell above the roof is still drawn
}

std::string readAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/// The SVG's map group redrawn as pixels: the ground rectangle's colour, then each path's
/// rectangles ("Mx yhWvHh-Wz") in their fill colour. Fails the test on anything else in the group.
std::vector<std::uint32_t> svgMapPixels(const std::string& svg, const TopViewInfo& info) {
  std::vector<std::uint32_t> px(static_cast<std::size_t>(info.map_width_px) * info.map_height_px, 0xFF000000u);
  const std::size_t g0 = svg.find("<g id=\"map\"");
  const std::size_t g1 = svg.find("</g>", g0);
  if (g0 == std::string::npos || g1 == std::string::npos) {
    ADD_FAILURE() << "no map group";
    return px;
  }
  const std::string g = svg.substr(g0, g1 - g0);
  auto fill = [&](int x, int y, int w, int h, std::uint32_t c) {
    for (int r = y - info.map_top_px; r < y - info.map_top_px + h; ++r)
      for (int i = x - info.map_left_px; i < x - info.map_left_px + w; ++i) {
        if (r < 0 || i < 0 || r >= info.map_height_px || i >= info.map_width_px) {
          ADD_FAILURE() << "a map rectangle outside the map area at " << i << "," << r;
          return;
        }
        px[static_cast<std::size_t>(r) * info.map_width_px + i] = c;
      }
  };
  int x, y, w, h;
  unsigned c;
  const std::size_t ground = g.find("<rect ");
  EXPECT_EQ(std::sscanf(g.c_str() + ground, "<rect x=\"%d\" y=\"%d\" width=\"%d\" height=\"%d\" fill=\"#%6x\"", &x, &y,
                        &w, &h, &c), 5);
  fill(x, y, w, h, c);
  for (std::size_t at = g.find("<path "); at != std::string::npos; at = g.find("<path ", at + 1)) {
    EXPECT_EQ(std::sscanf(g.c_str() + at, "<path fill=\"#%6x\"", &c), 1);
    std::size_t d = g.find("d=\"", at) + 3;
    const std::size_t end = g.find('"', d);
    while (d < end) {
      int back = 0, n = 0;
      if (std::sscanf(g.c_str() + d, "M%d %dh%dv%dh-%dz%n", &x, &y, &w, &h, &back, &n) != 5 || back != w || n == 0) {
        ADD_FAILURE() << "not a rectangle: " << g.substr(d, 40);
        return px;
      }
      fill(x, y, w, h, c);
      d += static_cast<std::size_t>(n);
    }
  }
  return px;
}

TEST_F(RenderTopViewTest, SvgIsVectorWithRealText) {
  TopViewOptions o;
  o.title = "junction <T> & branch";
  o.max_pixels = 300;
  TopViewInfo png_info, svg_info;
  ASSERT_TRUE(renderTopView(junction(), o, (dir_ / "top.png").string(), &png_info).ok());
  const fs::path out = dir_ / "top.SVG";  // extension is case-insensitive
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &svg_info).ok());
  ASSERT_EQ(svg_info.map_width_px, png_info.map_width_px);
  ASSERT_EQ(svg_info.map_left_px, png_info.map_left_px);
  const std::string text = readAll(out);
  ASSERT_GT(text.size(), 1000u);
  EXPECT_EQ(text.rfind("<?xml", 0), 0u) << text.substr(0, 80);
  EXPECT_NE(text.find("</svg>"), std::string::npos);
  // No embedded picture and no glyph outlines: the map is rectangles and the text is text.
  EXPECT_EQ(text.find("data:image/png;base64"), std::string::npos);
  EXPECT_EQ(text.find("glyph"), std::string::npos);
  EXPECT_NE(text.find(">junction &lt;T&gt; &amp; branch</text>"), std::string::npos);
  EXPECT_NE(text.find("<title>junction &lt;T&gt; &amp; branch</title>"), std::string::npos);
  std::size_t texts = 0;
  for (std::size_t at = text.find("<text "); at != std::string::npos; at = text.find("<text ", at + 1)) ++texts;
  EXPECT_GE(texts, 10u) << "title, caption, axis ticks, legend";
  EXPECT_NE(text.find("text-anchor=\"end\""), std::string::npos) << "the y axis' tick labels end at their tick";

  // Pixel for pixel, the SVG's map is the PNG's.
  const Picture png(dir_ / "top.png");
  ASSERT_TRUE(png.ok());
  const std::vector<std::uint32_t> svg_px = svgMapPixels(text, svg_info);
  std::size_t differ = 0, free_px = 0;
  for (int r = 0; r < svg_info.map_height_px; ++r)
    for (int i = 0; i < svg_info.map_width_px; ++i) {
      const std::uint32_t want = png.at(png_info.map_left_px + i, png_info.map_top_px + r);
      differ += svg_px[static_cast<std::size_t>(r) * svg_info.map_width_px + i] != want;
      free_px += want != kTopViewBackground;
    }
  EXPECT_EQ(differ, 0u);
  EXPECT_EQ(free_px, svg_info.free_pixels);
  EXPECT_GT(free_px, 100u);
}

TEST_F(RenderTopViewTest, ExplicitScaleIsUsed) {
  TopViewOptions o;
  o.pixels_per_m = 10.0;
  TopViewInfo info;
  const fs::path out = dir_ / "scaled.png";
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &info).ok());
  EXPECT_DOUBLE_EQ(info.pixels_per_m, 10.0);
  EXPECT_EQ(info.map_width_px, 175);   // 17.5 m
  EXPECT_EQ(info.map_height_px, 195);  // 19.5 m
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_NE(pic.atWorld(info, 10, 0), kTopViewBackground);
}

TEST_F(RenderTopViewTest, AutomaticScaleKeepsThinRoadwaysVisible) {
  // 300 m of 4 m roadway: max_pixels = 100 would make it 1.3 px wide; the scale is raised to 3 px.
  const map::OccupancyMap m =
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 300.0, 0.5));
  TopViewOptions o;
  o.max_pixels = 100;
  TopViewInfo info;
  const fs::path out = dir_ / "long.png";
  ASSERT_TRUE(renderTopView(m, o, out.string(), &info).ok());
  EXPECT_TRUE(info.scale_raised);
  EXPECT_NEAR(info.pixels_per_m, 0.75, 1e-9);
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  const int col = static_cast<int>(info.columnOf(150.0));
  int free_rows = 0;
  for (int r = info.map_top_px; r < info.map_top_px + info.map_height_px; ++r)
    free_rows += pic.at(col, r) != kTopViewBackground;
  EXPECT_GE(free_rows, 3);
  EXPECT_LE(free_rows, 5);
}

TEST_F(RenderTopViewTest, UnknownExtensionIsRefusedAndWritesNothing) {
  const std::string path = (dir_ / "top.jpg").string();
  const adit::Status s = renderTopView(junction(), {}, path);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
  EXPECT_TRUE(fs::is_empty(dir_));
  EXPECT_EQ(renderTopView(junction(), {}, (dir_ / "top").string()).code(), StatusCode::kInvalidArgument);
}

TEST_F(RenderTopViewTest, MissingDirectoryIsAnError) {
  const std::string path = (dir_ / "no_such_dir" / "top.png").string();
  const adit::Status s = renderTopView(junction(), {}, path);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("no_such_dir"), std::string::npos) << s.message();
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(RenderTopViewTest, DirectoryAsOutputIsAnErrorAndLeavesNoFile) {
  const fs::path target = dir_ / "taken.png";
  fs::create_directory(target);
  TopViewOptions o;
  o.max_pixels = 200;
  EXPECT_FALSE(renderTopView(junction(), o, target.string()).ok());
  EXPECT_TRUE(fs::is_directory(target));
  EXPECT_TRUE(fs::is_empty(target));
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1);  // no temporary file left beside it
}

TEST_F(RenderTopViewTest, TooLargePictureIsRefused) {
  TopViewOptions o;
  o.pixels_per_m = 2000.0;  // 35000 x 39000 px
  const std::string path = (dir_ / "huge.png").string();
  const adit::Status s = renderTopView(junction(), o, path);
  EXPECT_EQ(s.code(), StatusCode::kOutOfRange);
  EXPECT_NE(s.message().find("Mpx"), std::string::npos) << s.message();
  EXPECT_TRUE(fs::is_empty(dir_));

  // The automatic scale raised for thin roadways still honours the cap.
  const map::OccupancyMap m =
      test::voxelizeOrFail(test::straightRoadway(map::CrossSection::rectangle(4.0, 3.0), 300.0, 0.5));
  TopViewOptions tight;
  tight.max_pixels = 100;
  tight.max_megapixels = 0.01;
  const adit::Status t = renderTopView(m, tight, path);
  EXPECT_EQ(t.code(), StatusCode::kOutOfRange);
  EXPECT_NE(t.message().find("roadway"), std::string::npos) << t.message();
  EXPECT_TRUE(fs::is_empty(dir_));
}

TEST_F(RenderTopViewTest, InvalidOptionsAreRefused) {
  const std::string path = (dir_ / "top.png").string();
  TopViewOptions o;
  o.pixels_per_m = std::nan("");
  EXPECT_EQ(renderTopView(junction(), o, path).code(), StatusCode::kInvalidArgument);
  o = {};
  o.pixels_per_m = -1;
  EXPECT_EQ(renderTopView(junction(), o, path).code(), StatusCode::kInvalidArgument);
  o = {};
  o.slice_z_m = std::numeric_limits<double>::infinity();
  EXPECT_EQ(renderTopView(junction(), o, path).code(), StatusCode::kInvalidArgument);
  o = {};
  o.slice_z_m = 1.0;
  o.slice_band_m = -0.5;
  EXPECT_EQ(renderTopView(junction(), o, path).code(), StatusCode::kInvalidArgument);
  o = {};
  o.max_pixels = 0;
  EXPECT_EQ(renderTopView(junction(), o, path).code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(fs::is_empty(dir_));
}

}  // namespace
}  // namespace adit::tools

// ---- Figure: overlays, open space, side profile ----------------------------------------------

namespace adit::tools::figure_test {

class FigureTest : public RenderTopViewTest {};

TEST_F(FigureTest, SliceExactlyOnVoxelBoundariesDrawsTheFreeVoxelAbove) {
  // Regression: a slice height on a voxel boundary met neither voxel (OctoMap's float centre of
  // the one above is a hair over the boundary), so free space was drawn as unknown. It shows on
  // unpruned leaves (scans, sensed voxels), so the map is a block of single free voxels.
  auto tree = std::make_shared<octomap::OcTree>(0.1);
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      for (int k = 0; k < 12; ++k)
        tree->updateNode(octomap::point3d(0.05f + 0.1f * i, 0.05f + 0.1f * j, 0.05f + 0.1f * k), false,
                         /*lazy_eval=*/true);
  auto m = map::OccupancyMap::create(tree);
  ASSERT_TRUE(m.ok()) << m.status().message();
  for (double z : {0.3, 0.5, 0.7, 1.0}) {
    TopViewOptions o;
    o.max_pixels = 100;
    o.slice_z_m = z;
    TopViewInfo info;
    const fs::path out = dir_ / "slice.png";
    ASSERT_TRUE(renderTopView(*m, o, out.string(), &info).ok());
    Picture pic(out);
    ASSERT_TRUE(pic.ok());
    EXPECT_EQ(pic.atWorld(info, 1.0, 1.0), kTopViewSliceFree) << "z = " << z;
    EXPECT_GE(info.free_pixels, 0.95 * info.map_width_px * info.map_height_px) << "z = " << z;
  }
}

TEST_F(FigureTest, OverlaysAreDrawnAtTheirWorldPositions) {
  TopViewOptions o;
  o.max_pixels = 600;
  Figure fig(o);
  fig.setMap(&junction());
  fig.addLine({{map::Vec3(1, 0, 1), map::Vec3(13, 0, 1)}, 0x00FF00, 4.0, false, {}, "path"});
  fig.addDisc({map::Vec3(6, -5, 1), 0.8, 0x0000FF, 1.0, 0x0000FF, "", "obstacle"});
  fig.addMarker({map::Vec3(14, 6, 1), MarkerShape::kSquare, 0xFF00FF, 12.0, "A", "break point"});
  TopViewInfo info;
  const fs::path out = dir_ / "overlays.png";
  ASSERT_TRUE(fig.render(out.string(), &info).ok());
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_EQ(pic.atWorld(info, 7, 0), 0x00FF00u);
  EXPECT_EQ(pic.atWorld(info, 6, -5), 0x0000FFu);
  EXPECT_EQ(pic.atWorld(info, 14, 6), 0xFF00FFu);
  // the map under the overlays is unchanged elsewhere
  EXPECT_NE(pic.atWorld(info, 10, 1.5), kTopViewBackground);
}

TEST_F(FigureTest, PngInMemoryEqualsTheFile) {
  Figure fig;
  fig.setMap(&junction());
  fig.addLine({{map::Vec3(1, 0, 1), map::Vec3(13, 0, 1)}, kFigurePath, 2.0, true, {}, ""});
  const fs::path out = dir_ / "a.png";
  TopViewInfo a, b;
  ASSERT_TRUE(fig.render(out.string(), &a).ok());
  std::vector<unsigned char> png;
  ASSERT_TRUE(fig.renderPng(&png, &b).ok());
  std::ifstream in(out, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(std::string(png.begin(), png.end()), file);
  EXPECT_EQ(a.map_left_px, b.map_left_px);
  EXPECT_EQ(a.pixels_per_m, b.pixels_per_m);
}

TEST_F(FigureTest, OpenSpaceFigureTakesItsExtentFromTheOverlays) {
  Figure fig;
  std::vector<map::Vec3> traj;
  std::vector<double> t;
  for (int k = 0; k <= 20; ++k) {
    traj.emplace_back(0.7 * k, 0.7 * k, 0);
    t.push_back(0.5 * k);
  }
  fig.addLine({traj, kFigureTrajectory, 3.0, false, t, "trajectory", "time [s]"});
  fig.addDisc({map::Vec3(9, 11.5, 0), 0.5, kFigureObstacle, 0.6, kFigureObstacle, "", "static obstacle"});
  TopViewInfo info;
  const fs::path out = dir_ / "open.svg";
  ASSERT_TRUE(fig.render(out.string(), &info).ok());
  EXPECT_LE(info.x_min_m, 0.0);
  EXPECT_GE(info.y_max_m, 14.0);
  const std::string text = readAll(out);
  EXPECT_NE(text.find("</svg>"), std::string::npos);
  EXPECT_EQ(text.find("data:image/png;base64"), std::string::npos);  // no raster without a map
  EXPECT_EQ(text.find("<g id=\"map\""), std::string::npos);         // and no map layer
  EXPECT_NE(text.find(">time [s]</text>"), std::string::npos);        // the colour bar's caption
}

TEST_F(FigureTest, ProfilePanelAddsItsHeight) {
  Figure plain;
  plain.setMap(&junction());
  Figure with = plain;
  SideProfile p;
  p.series.push_back({{0, 5, 12, 20}, {1.0, 1.2, 1.4, 3.0}, kFigurePath, 2.0, false, "path"});
  p.series.push_back({{0, 20}, {0.0, 2.0}, 0x8E735C, 1.5, true, "floor"});
  p.labels.push_back({12, 1.4, "A"});
  with.setProfile(p);
  TopViewInfo a, b;
  ASSERT_TRUE(plain.render((dir_ / "plain.png").string(), &a).ok());
  ASSERT_TRUE(with.render((dir_ / "profile.png").string(), &b).ok());
  EXPECT_GT(b.height_px, a.height_px + 150);
  EXPECT_EQ(a.map_left_px, b.map_left_px);
}

TEST_F(FigureTest, InvalidOverlaysAreRefusedAndWriteNothing) {
  const double nan = std::nan("");
  auto refused = [&](Figure fig, const std::string& needle) {
    const fs::path out = dir_ / "bad.png";
    const Status s = fig.render(out.string());
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
    EXPECT_FALSE(fs::exists(out));
  };
  Figure a;
  a.addLine({{map::Vec3(0, 0, 0), map::Vec3(nan, 1, 0)}});
  refused(a, "line 0");
  Figure b;
  b.addLine({{map::Vec3(0, 0, 0), map::Vec3(1, 1, 0)}, kFigurePath, 2.0, false, {1.0}});
  refused(b, "1 values for 2 points");
  Figure c;
  c.addDisc({map::Vec3(0, 0, 0), -1.0});
  refused(c, "radius_m");
  Figure d;  // nothing at all
  refused(d, "nothing to draw");
  Figure e;
  e.addMarker({map::Vec3(0, 0, 0)});
  SideProfile p;
  p.series.push_back({{0, 1}, {0}});
  e.setProfile(p);
  refused(e, "differ in length");
}

}  // namespace adit::tools::figure_test

namespace adit::tools::figure_test {

TEST_F(FigureTest, ViewBoxDrawsOnlyThatPartOfTheMap) {
  TopViewOptions o;
  o.pixels_per_m = 20.0;
  o.view_box_m = map::Aabb(map::Vec3(8, -3, -100), map::Vec3(16, 3, 100));
  TopViewInfo info;
  const fs::path out = dir_ / "view.png";
  ASSERT_TRUE(renderTopView(junction(), o, out.string(), &info).ok());
  EXPECT_NEAR(info.x_min_m, 8.0, 1e-9);
  EXPECT_NEAR(info.y_max_m, 3.0, 1e-9);
  EXPECT_EQ(info.map_width_px, 160);
  EXPECT_EQ(info.map_height_px, 120);
  Picture pic(out);
  ASSERT_TRUE(pic.ok());
  EXPECT_NE(pic.atWorld(info, 10, 0), kTopViewBackground);  // the main roadway, inside the view
  // A view whose top row is the rock beside the main roadway (y < -2): the free roadway just
  // above the view must not leak into that row.
  TopViewOptions below = o;
  below.view_box_m = map::Aabb(map::Vec3(8, -8, -100), map::Vec3(14, -2.5, 100));
  TopViewInfo binfo;
  const fs::path bout = dir_ / "below.png";
  ASSERT_TRUE(renderTopView(junction(), below, bout.string(), &binfo).ok());
  Picture bpic(bout);
  ASSERT_TRUE(bpic.ok());
  for (double x = 8.5; x < 14.0; x += 0.5) EXPECT_EQ(bpic.atWorld(binfo, x, -2.52), kTopViewBackground) << x;
  TopViewOptions off = o;
  off.view_box_m = map::Aabb(map::Vec3(500, 500, 0), map::Vec3(600, 600, 1));
  EXPECT_FALSE(renderTopView(junction(), off, (dir_ / "off.png").string()).ok());
}

// Break points as the district plan has them (H and I 1.1 m apart, L beside the goal): every label is
// placed clear (the figure reports no overlap), the crowded ones share a label, and the start and
// goal markers are still their own colour at their centres, so no label was drawn over them.
TEST_F(RenderTopViewTest, CrowdedMarkerLabelsDoNotOverlap) {
  TopViewOptions o;
  o.pixels_per_m = 10;  // 1.1 m is 11 px, closer than a label is tall
  Figure fig(o);
  fig.setWorldBounds(map::Aabb(map::Vec3(-2, -2, 0), map::Vec3(40, 12, 0)));
  const std::vector<map::Vec3> bp = {{3, 0, 0},   {8, 1, 0},    {13, 0, 0},   {18, 2, 0},   {23, 2, 0}, {26, 3, 0},
                                     {29, 3, 0}, {32, 4, 0},   {33.1, 4, 0}, {34, 7, 0},   {35, 9, 0}, {36, 9.4, 0}};
  for (std::size_t i = 0; i < bp.size(); ++i)
    fig.addMarker({bp[i], MarkerShape::kCircle, kFigureBreakPoint, 7, std::string(1, char('A' + i)), ""});
  const map::Vec3 start(0, 0, 0), goal(36.8, 9.4, 0);
  fig.addMarker({start, MarkerShape::kCircle, kFigureStart, 10, "start", "start", 0});
  fig.addMarker({goal, MarkerShape::kSquare, kFigureGoal, 10, "goal", "goal", 0});
  for (const char* name : {"labels.png", "labels.svg"}) {
    TopViewInfo info;
    ASSERT_TRUE(fig.render((dir_ / name).string(), &info).ok()) << name;
    EXPECT_LT(info.labels, 14u) << "crowded markers share a label";
    EXPECT_GE(info.labels_merged, 2u);
    EXPECT_EQ(info.label_overlaps, 0u);
    if (std::string(name) == "labels.svg") {  // the labels as haloed text, each once
      const std::string svg = readAll(dir_ / name);
      std::vector<std::string> haloed;
      for (std::size_t at = svg.find("<text "); at != std::string::npos; at = svg.find("<text ", at + 1)) {
        const std::size_t open_end = svg.find('>', at), close = svg.find("</text>", at);
        if (svg.substr(at, open_end - at).find("paint-order=\"stroke\"") != std::string::npos)
          haloed.push_back(svg.substr(open_end + 1, close - open_end - 1));
      }
      EXPECT_EQ(haloed.size(), info.labels);
      for (const char* label : {"start", "goal", "A"})
        EXPECT_EQ(std::count(haloed.begin(), haloed.end(), label), 1) << label;
    }
    if (std::string(name) == "labels.png") {
      Picture pic(dir_ / name);
      ASSERT_TRUE(pic.ok());
      EXPECT_EQ(pic.atWorld(info, start.x(), start.y()), kFigureStart);
      EXPECT_EQ(pic.atWorld(info, goal.x(), goal.y()), kFigureGoal);
    }
  }
}

}  // namespace adit::tools::figure_test
